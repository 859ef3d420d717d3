"""Reference definitions (numpy only) of every op shared by PyTorch, the emulator and GLSL.

Slow and exact on purpose: the other implementations are tested against these.
"""
