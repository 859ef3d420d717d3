"""Shipped checkpoints: ``<name>.pt`` files written by ``mnss_kit.model.checkpoint.save``.

``mnss_kit.model.checkpoint.load("<name>")`` and ``mnss-kit models`` find them here.

``mnss_x2.pt``: ``mnss_kit/configs/models/mnss_x2.yaml`` trained by ``mnss-kit train mnss_x2`` on
``mnss-kit render train_x2`` (the record holds the data fingerprint and training summary).
``fusesr_x2_hybrid.pt`` and ``fusesr_x4_l.pt``: the configs of the same names, trained on
``train_x2`` and ``train_x4`` (README, *Reproducing the shipped models*; docs/fusesr_shipped.md).
"""
