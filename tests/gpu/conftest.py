"""One Mesa (EGL) context for the whole session, and the numpy reference passes."""

from __future__ import annotations

import pytest

from mnss_kit.gpu.reference import ReferencePasses


@pytest.fixture(scope="session")
def mesa():
    from mnss_kit.gpu.mesa import MesaPasses

    return MesaPasses()


@pytest.fixture(scope="session")
def ref():
    return ReferencePasses()
