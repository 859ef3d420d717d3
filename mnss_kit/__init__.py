"""mnss-kit: neural supersampling for real-time rendering on phones.

Stages, in the order data moves: render -> dataset -> model -> train -> eval
-> quantize -> split -> export -> emulate.  Reference definitions of every op
shared between PyTorch, numpy and GLSL live in ``mnss_kit.ops``.
"""

__version__ = "0.1.0"
