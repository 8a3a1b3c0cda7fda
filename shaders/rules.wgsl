// placeholder: rules is not written yet
