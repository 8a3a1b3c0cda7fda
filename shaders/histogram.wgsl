// placeholder: histogram is not written yet
