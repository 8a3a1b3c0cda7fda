// placeholder: response is not written yet
