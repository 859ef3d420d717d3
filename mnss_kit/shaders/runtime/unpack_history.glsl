// Unpack (MNSS): the int8 NPU output, NHWC (1, H, W, 3) packed four bytes per word, dequantized
// exactly (ops.int8.quantize.dequantize).  Binding-free.

#include "common.glsl"
#include "display.glsl"
