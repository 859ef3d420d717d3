"""Built-in G-buffer renderer (OpenGL through EGL) and scene import."""
