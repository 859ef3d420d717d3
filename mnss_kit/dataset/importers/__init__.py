"""Importers from capture formats users already have into the toolkit's dataset format.

One module per source format (``nss``, ``images``); ``publish`` is what every importer
ends with: the datasets are written into a staging directory, checked with the checks of
``mnss-kit data check``, and only then moved to the output.
"""
