// placeholder: orientation is not written yet
