// placeholder: orb is not written yet
