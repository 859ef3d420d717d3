"""Built-in G-buffer renderer (OpenGL 3.3 through EGL) and scene import.

    config.py     data config (mnss_kit/configs/data/*.yaml) -> SequenceConfig
    scenes/       built-in scenes (arena, town, flight, factory) and the glTF/OBJ import hook
    camera.py     matrices, jitter, keyframed camera paths (camera-path YAML format)
    renderer.py   shadow map, deferred G-buffer, lighting, particles; LR + 16-spp HR reference
    run.py        render_dataset: frames -> dataset sequences (sharding, resume, meta.json)
    command.py    ``mnss-kit render``
"""
