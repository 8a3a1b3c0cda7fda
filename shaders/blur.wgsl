// placeholder: blur is not written yet
