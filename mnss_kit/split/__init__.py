"""Split stage: place each model stage on the GPU or the NPU of a device and estimate its cost.

``device`` reads a device profile (``mnss_kit/configs/devices/NAME.yaml``); ``trace`` runs one small
frame through a model and records, per stage, the TFLite ops it needs, its bytes and the
tensors flowing between stages; ``estimate`` turns MACs and bytes into estimated milliseconds
(roofline); ``plan.split_model`` picks the placement and builds the report; ``run.run_split`` is the
entry function (``mnss-kit split``).
Light on purpose (no torch at import).
"""
