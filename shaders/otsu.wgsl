// placeholder: otsu is not written yet
