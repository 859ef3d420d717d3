"""Image and temporal quality metrics shared by training, evaluation and quantization.

``image``    PSNR, SSIM (PyTorch, differentiable; numpy wrappers)
``temporal`` IF-SSIM and the temporal warping error
``flip``     FLIP through flip-evaluator (imported on use)
"""

from .image import psnr, psnr_torch, ssim, ssim_image, ssim_map, ssim_map_image
from .temporal import TemporalMasks, if_ssim, temporal_error, temporal_masks, temporal_scores

__all__ = [
    "psnr",
    "psnr_torch",
    "ssim",
    "ssim_image",
    "ssim_map",
    "ssim_map_image",
    "TemporalMasks",
    "if_ssim",
    "temporal_error",
    "temporal_masks",
    "temporal_scores",
]
