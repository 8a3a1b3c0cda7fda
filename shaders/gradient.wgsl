// placeholder: gradient is not written yet
