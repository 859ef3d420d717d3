"""The GPU stage of the phone runtime: GLSL ES 3.10 compute passes and their numpy reference.

``glsl``       reads the pass files (``mnss_kit/shaders/runtime``) and flattens their includes
``passes``     the passes as data: entry file, workgroup size, bindings, formats
``weights``    the learned convs of the GPU stage, packed for the shaders
``reference``  numpy definition of every pass (the emulator's GPU stage)
``mesa``       the shader files run on Mesa through EGL, same interface as ``reference``
``schedule``   one frame through the passes, before and after the NPU

No torch here: a model's weights arrive as a numpy state dict.
"""
