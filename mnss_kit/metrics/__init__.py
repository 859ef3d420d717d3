"""Image and temporal quality metrics shared by training, evaluation, quantization and the emulator.

``psnr``     PSNR in numpy (no torch: the emulator imports it); ``inf`` for identical images
``image``    SSIM (PyTorch, differentiable; numpy wrappers) and PSNR of tensors
``temporal`` IF-SSIM and the temporal warping error
``flip``     FLIP through flip-evaluator (imported on use)

Import the torch modules by name (``from mnss_kit.metrics.image import ssim``): this package
itself loads only the numpy part, so importing it never loads torch.
"""

from .psnr import mse_psnr, psnr

__all__ = ["mse_psnr", "psnr"]
