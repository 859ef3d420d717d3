"""Conventions, written once and imported everywhere.

Images
    numpy images are ``(H, W, C)``; PyTorch tensors ``(N, C, H, W)``; the NPU
    boundary is ``(N, H, W, C)`` (NHWC).  Row 0 is the top of the screen.
Pixel centres
    Pixel ``(x, y)`` covers ``[x, x+1) x [y, y+1)`` and its centre is at
    ``(x + 0.5, y + 0.5)`` in pixel coordinates.  Screen UV is pixel / size,
    so UV ``(0, 0)`` is the top-left corner.
Motion vectors (canonical, what the loader hands to the model)
    ``mv[y, x] = (dx, dy)`` in pixels of the buffer's own resolution,
    +x right, +y down, pointing from the current frame to the previous one:
    the surface seen at pixel centre ``p`` this frame was at ``p + mv`` in the
    previous frame.  Motion is rendered without the sub-pixel jitter.  An LR
    motion field becomes an HR one by bilinear upsampling and multiplying by
    the scale.
Jitter
    ``(jx, jy)`` in LR pixels relative to the pixel centre, each in
    ``[-0.5, 0.5)``, +x right, +y down.  LR pixel ``(i, j)`` shades the
    screen point ``(j + 0.5 + jx, i + 0.5 + jy)`` (LR pixel units).
Depth (canonical)
    Linear view depth normalised to ``[0, 1]``: ``(z - near) / (far - near)``,
    0 at the near plane.  Engines write hardware depth (standard or reverse-Z);
    the loader converts once, at the edge.
Warp border mode
    Clamp to edge: a sample that falls off-screen reads the nearest edge texel.
Colour
    Datasets store linear HDR colour; the model sees display values in
    ``[0, 1]`` from ``mnss_kit.ops.colour.to_display``.
"""

LAYOUT_TORCH = "NCHW"
LAYOUT_NPU = "NHWC"
PIXEL_CENTER = 0.5
MOTION_UNITS = "pixels"
MOTION_POINTS_TO = "previous"
MOTION_Y_AXIS = "down"
JITTER_UNITS = "lr_pixels"
WARP_BORDER = "clamp"
