"""Desktop emulator of the NPU part: integer-exact int8 kernels per runtime kernel set (no torch)."""
