"""The Mesa GPU backend on the bundle's own shader files.

:class:`mnss_kit.gpu.mesa.MesaPasses` compiles the toolkit's copy of each pass; a bundle
carries the flattened files a phone compiles (``gpu.passes[].file``).  The emulator compiles
those (verified against the manifest's hashes when the bundle was opened), so what runs is what
ships.  Bindings and uniforms are the ones ``mnss_kit.gpu.passes`` declares; ``bundle check``
verifies the manifest lists the same.
"""

from __future__ import annotations

from pathlib import Path

from .bundle import BundleSpec


def bundle_mesa_passes(spec: BundleSpec):
    """A ``MesaPasses`` compiling the bundle's shader files (the package's when the bundle was built in memory)."""
    from ..gpu.mesa import MesaPasses

    if "gpu" not in spec.manifest:  # assembled in memory: the package's shaders
        return MesaPasses()
    root = Path(spec.source)
    return MesaPasses(sources={p["name"]: root / p["file"] for p in spec.manifest["gpu"]["passes"]})
