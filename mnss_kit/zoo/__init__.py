"""Shipped checkpoints: ``<name>.pt`` files written by ``mnss_kit.model.checkpoint.save``.

``mnss_kit.model.checkpoint.load("<name>")`` and ``mnss-kit models`` find them here.
None is shipped yet; training adds them.
"""
