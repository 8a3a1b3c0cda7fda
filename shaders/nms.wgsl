// placeholder: nms is not written yet
