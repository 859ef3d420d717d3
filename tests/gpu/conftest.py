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


@pytest.fixture(scope="module")
def gl(request):
    """The session's Mesa context, for tests that skip where EGL or Mesa is missing."""
    try:
        return request.getfixturevalue("mesa")
    except Exception as e:  # noqa: BLE001 (no EGL display, no GL 4.3 context, no moderngl)
        pytest.skip(f"no Mesa/EGL context: {e}")


@pytest.fixture(scope="session")
def ref():
    return NamedPasses(ReferencePasses())
