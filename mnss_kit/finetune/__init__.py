"""Fine-tuning a model on a studio's own capture, judged on the frames it held back (``mnss-kit finetune``)."""
