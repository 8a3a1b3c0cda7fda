// placeholder: luma is not written yet
