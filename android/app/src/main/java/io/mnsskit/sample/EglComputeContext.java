package io.mnsskit.sample;

import android.opengl.EGL14;
import android.opengl.EGLConfig;
import android.opengl.EGLContext;
import android.opengl.EGLDisplay;
import android.opengl.EGLExt;
import android.opengl.EGLSurface;
import android.opengl.GLES30;

/**
 * An off-screen OpenGL ES 3.1 context, current on the thread that creates it: compute passes
 * need no window.  Every GL call of the pipeline must run on that thread.
 */
final class EglComputeContext implements AutoCloseable {
    private final EGLDisplay display;
    private final EGLContext context;
    private final EGLSurface surface;

    EglComputeContext() {
        display = EGL14.eglGetDisplay(EGL14.EGL_DEFAULT_DISPLAY);
        int[] version = new int[2];
        if (display == EGL14.EGL_NO_DISPLAY || !EGL14.eglInitialize(display, version, 0, version, 1)) {
            throw new IllegalStateException("cannot initialise EGL: 0x" + Integer.toHexString(EGL14.eglGetError()));
        }
        int[] configAttribs = {
            EGL14.EGL_RENDERABLE_TYPE, EGLExt.EGL_OPENGL_ES3_BIT_KHR,
            EGL14.EGL_SURFACE_TYPE, EGL14.EGL_PBUFFER_BIT,
            EGL14.EGL_NONE,
        };
        EGLConfig[] configs = new EGLConfig[1];
        int[] count = new int[1];
        if (!EGL14.eglChooseConfig(display, configAttribs, 0, configs, 0, 1, count, 0) || count[0] == 0) {
            throw new IllegalStateException("no EGL config with OpenGL ES 3 and pbuffers");
        }
        int[] contextAttribs = {EGL14.EGL_CONTEXT_CLIENT_VERSION, 3, EGL14.EGL_NONE};
        context = EGL14.eglCreateContext(display, configs[0], EGL14.EGL_NO_CONTEXT, contextAttribs, 0);
        if (context == EGL14.EGL_NO_CONTEXT) {
            throw new IllegalStateException("cannot create an OpenGL ES 3 context: 0x" + Integer.toHexString(EGL14.eglGetError()));
        }
        int[] surfaceAttribs = {EGL14.EGL_WIDTH, 1, EGL14.EGL_HEIGHT, 1, EGL14.EGL_NONE};
        surface = EGL14.eglCreatePbufferSurface(display, configs[0], surfaceAttribs, 0);
        if (!EGL14.eglMakeCurrent(display, surface, surface, context)) {
            throw new IllegalStateException("eglMakeCurrent failed: 0x" + Integer.toHexString(EGL14.eglGetError()));
        }
        int[] major = new int[1];
        int[] minor = new int[1];
        GLES30.glGetIntegerv(GLES30.GL_MAJOR_VERSION, major, 0);
        GLES30.glGetIntegerv(GLES30.GL_MINOR_VERSION, minor, 0);
        if (major[0] < 3 || (major[0] == 3 && minor[0] < 1)) {
            close();
            throw new IllegalStateException("the bundle's compute shaders need OpenGL ES 3.1; this device has " + major[0] + "." + minor[0]);
        }
    }

    /** Renderer and version strings, for the self-test report. */
    String describe() {
        return GLES30.glGetString(GLES30.GL_RENDERER) + ", " + GLES30.glGetString(GLES30.GL_VERSION);
    }

    @Override
    public void close() {
        EGL14.eglMakeCurrent(display, EGL14.EGL_NO_SURFACE, EGL14.EGL_NO_SURFACE, EGL14.EGL_NO_CONTEXT);
        EGL14.eglDestroySurface(display, surface);
        EGL14.eglDestroyContext(display, context);
        EGL14.eglReleaseThread();
    }
}
