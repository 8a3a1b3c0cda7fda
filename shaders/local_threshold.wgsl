// placeholder: local_threshold is not written yet
