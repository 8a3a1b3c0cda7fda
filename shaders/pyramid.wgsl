// placeholder: pyramid is not written yet
