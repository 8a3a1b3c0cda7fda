// placeholder: hysteresis is not written yet
