"""int8 post-training quantization of the NPU stage: trace -> calibrate -> quantize -> npu.tflite / npu_qdq.onnx.

``graph`` holds the quantized graph (the single source of truth for scales
and zero points), ``trace`` builds it from a float module, ``calibrate`` and
``params`` decide the parameters, ``tflite_writer`` and ``onnx_writer`` write
it, ``runtime`` runs it, ``sensitivity`` and ``fakequant`` measure and
fine-tune it, ``stage`` and ``command`` put it together.
"""
