// placeholder: corner_nms is not written yet
