"""Model stage: the MNSS family, its config ladder, MAC counting and checkpoints.

Light on purpose (no torch at import): ``mnss_kit.model.command`` must load fast.
Build a model with ``families.build_model(config.load_model_config(name))``;
load a trained one with ``checkpoint.load(path_or_name)``.
"""
