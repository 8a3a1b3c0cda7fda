// placeholder: select is not written yet
