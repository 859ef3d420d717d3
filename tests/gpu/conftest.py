"""One Mesa (EGL) context for the whole session, and the numpy reference passes; both with the
positional pass methods of ``pass_calls.NamedPasses``."""

from __future__ import annotations

import pytest
from pass_calls import NamedPasses

from mnss_kit.gpu.reference import ReferencePasses


@pytest.fixture(scope="session")
def mesa():
    from mnss_kit.gpu.mesa import MesaPasses

    return NamedPasses(MesaPasses())


@pytest.fixture(scope="session")
def ref():
    return NamedPasses(ReferencePasses())
