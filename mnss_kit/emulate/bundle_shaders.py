"""The Mesa GPU backend on the bundle's own shader files.

:class:`mnss_kit.gpu.mesa.MesaPasses` compiles the toolkit's copy of each pass; a bundle
carries the flattened files a phone compiles (``gpu.passes[].file``).  The emulator compiles
those (verified against the manifest's hashes when the bundle was opened), so what runs is what
ships.  Bindings and uniforms are the ones ``mnss_kit.gpu.passes`` declares; ``bundle check``
verifies the manifest lists the same.
"""

from __future__ import annotations

from pathlib import Path

from ..errors import UserError
from .bundle import BundleSpec


def bundle_mesa_passes(spec: BundleSpec):
    """A ``MesaPasses`` compiling the bundle's shader files (the package's when the bundle was built in memory)."""
    from ..gpu.mesa import MesaPasses

    if spec.manifest is None:
        return MesaPasses()
    root = Path(spec.source)
    sources = {p["name"]: p["file"] for p in spec.manifest["gpu"]["passes"]}

    class BundlePasses(MesaPasses):
        def program(self, name: str):
            if name not in self._programs:
                if name not in sources:
                    raise UserError(f"{root / 'manifest.json'}: gpu.passes has no {name}")
                text = (root / sources[name]).read_text(encoding="utf-8", errors="replace")
                try:
                    self._programs[name] = self.compile(text)
                except Exception as e:  # moderngl raises plain Exceptions with the driver's compile log
                    first = str(e).strip().splitlines()[0] if str(e).strip() else type(e).__name__
                    raise UserError(f"{root / sources[name]}: does not compile on this GL driver ({first})") from None
            return self._programs[name]

    return BundlePasses()
