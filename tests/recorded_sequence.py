"""The recorded sequence the test bundles carry (``mnss-kit export --sequence``), shared by the
export and Android tests (a module of its own: two conftest modules cannot both be imported)."""

SEQUENCE_FRAMES = 6  # recorded frames the bundle carries for playback (the synthetic sequences have 8)
