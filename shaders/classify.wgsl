// placeholder: classify is not written yet
