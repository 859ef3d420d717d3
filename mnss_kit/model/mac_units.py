"""Unit costs of fixed-function GPU arithmetic, in MACs, for the families' ``fixed_macs`` rules
(the whole rule table is in ``model.macs``)."""

BILINEAR = 4  # one bilinear sample of one channel: four weighted taps
