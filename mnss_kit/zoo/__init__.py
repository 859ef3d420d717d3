"""Shipped checkpoints: ``<name>.pt`` files written by ``mnss_kit.model.checkpoint.save``.

``mnss_kit.model.checkpoint.load("<name>")`` and ``mnss-kit models`` find them here.

``mnss_x2.pt``: ``mnss_kit/configs/models/mnss_x2.yaml`` trained by ``mnss-kit train mnss_x2`` on
``mnss-kit render train_x2`` (the record holds the data fingerprint and training summary).
"""
