"""Desktop emulator: a bundle's frame loop on a CPU, bit-exact to named NPU runtimes (no torch).

``frame_loop``      :class:`~.frame_loop.Emulator`: GPU passes, NPU graph, GPU passes, history
``bundle``          what the frame loop reads from a bundle (schedule, weights, NPU files)
``bundle_shaders``  the Mesa GPU backend on the bundle's own shader files
``npu``             NPU backends (numpy interpreter, LiteRT, ONNX Runtime) per runtime (``ops.runtimes``)
``npu_graph``       ``npu.tflite`` read into plain data; ``interpreter`` runs it op by op
``kernels``         integer-exact int8 kernels under a runtime's formulas
``fast``, ``fast_gpu``  faster paths with results identical to the kernels and GPU reference
``run``             dataset sequences through the emulator (``run_dataset``): PNGs, metrics, dumps
``dump``, ``compare``   tensor dumps (emulator and device) and their layer-by-layer comparison
``command``         ``mnss-kit emulate``
"""
