"""The GPU stage of the phone runtime: GLSL ES 3.10 compute passes and their numpy reference.

``glsl``       reads the pass files (``mnss_kit/shaders/runtime``) and flattens their includes
``passes/``    one file per pass: its record (workgroup size, grid, bindings, uniforms, formats)
               and its numpy reference; ``passes.PASSES`` in execution order
``storage``    what the GPU's storage does to values (fp16 rounding, 8-bit display codes)
``weights``    the learned convs of the GPU stage, packed for the shaders
``reference``  the numpy backend (the emulator's GPU stage): ``run_pass(name, call)``
``mesa``       the shader files run on Mesa through EGL, the same ``run_pass`` from the record
``plan``       building blocks of a family's GPU plan (steps, uniforms, weight blocks)
``interpret``  one frame of a bundle's schedule through the passes, before and after the NPU

No torch here: a model's weights arrive as a numpy state dict.
"""
