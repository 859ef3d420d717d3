"""Export stage: the deployment bundle a phone app and the desktop emulator read.

``run.export`` is the entry function (``mnss-kit export``); ``writer`` assembles the files
and the manifest; ``check.check_bundle`` verifies a bundle (``mnss-kit bundle check``).  The
manifest format is ``manifest`` (version gate, hashes) plus ``mnss_kit/schemas/manifest.schema.json``;
``docs/bundle.md`` describes it for an engine integrator.
Light on purpose (no torch at import).
"""
