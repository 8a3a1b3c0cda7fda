// placeholder: lfast is not written yet
