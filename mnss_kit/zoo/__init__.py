"""Shipped checkpoints: ``<name>.pt`` files written by ``mnss_kit.model.checkpoint.save``.

``mnss_kit.model.checkpoint.load("<name>")`` and ``mnss-kit models`` find them here.

``ntaau_lr_x2.pt`` (the default, :data:`DEFAULT_MODEL`): the config of the same name, an
encoder-decoder at LR that steers TAAU from depth and motion evidence with a spatial fallback and a
history at least TAAU's on still pixels, trained by ``mnss-kit train ntaau_lr_x2`` on
``train_engine_x2`` and its engine variant against the 16-sample box reference (docs/results.md,
docs/results_engine.md, docs/studies/ntaau_lr.md).
``ntaau_lr_modes.pt``: one checkpoint for the quality modes (1.5x, 1.7x, 2x, 3x and between), the
default's design reading 1/s as one more input, trained by ``mnss-kit train ntaau_lr_modes`` from
``ntaau_lr_x2`` on ``train_modes_x2`` and ``train_engine_x2`` (docs/modes.md).
``ntaau_x2.pt`` (the default before it) and ``ntaau_x2_fast.pt``: the configs of the
same names, small nets that steer the toolkit's TAAU and its display filter, trained by
``mnss-kit train ntaau_x2_base`` then ``ntaau_x2``, which fine-tunes it (and the same for
``ntaau_x2_fast``) on ``train_x2`` rendered with the grid jitter,
centre (no jitter) and Halton, ``train_rooms_x2`` and ``train_still_x2`` (docs/training.md, *Reproducing
the shipped models*; docs/results.md).  ``mnss_x2.pt``: ``mnss_kit/configs/models/mnss_x2.yaml`` trained
by ``mnss-kit train mnss_x2`` on ``mnss-kit render train_x2`` (the record holds the data
fingerprint and training summary), the paper's design.
``fusesr_x2_hybrid.pt`` and ``fusesr_x4_l.pt``: the configs of the same names, trained on
``train_x2`` and ``train_x4`` (docs/training.md, *Reproducing the shipped models*; docs/fusesr_shipped.md).
"""

# The model the demo, the stress suite and the docs use when none is named: at or above the
# toolkit's TAAU on every sequence of the held-out sets in every input variant (docs/results.md),
# with its NPU boundary at LR.
DEFAULT_MODEL = "ntaau_lr_x2"
