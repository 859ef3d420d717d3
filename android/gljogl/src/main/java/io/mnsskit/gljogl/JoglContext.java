package io.mnsskit.gljogl;

import com.jogamp.nativewindow.AbstractGraphicsDevice;
import com.jogamp.nativewindow.DefaultGraphicsDevice;
import com.jogamp.nativewindow.NativeWindowFactory;
import com.jogamp.opengl.GL4ES3;
import com.jogamp.opengl.GLAutoDrawable;
import com.jogamp.opengl.GLCapabilities;
import com.jogamp.opengl.GLContext;
import com.jogamp.opengl.GLDrawableFactory;
import com.jogamp.opengl.GLProfile;
import com.jogamp.opengl.GLRendererQuirks;

/**
 * An off-screen OpenGL ES 3.x context from JOGL 2.3.2 with no display (Mesa llvmpipe), current on
 * the creating thread.  Run the JVM with {@code EGL_PLATFORM=surfaceless} and
 * {@code -Djogl.disable.opengldesktop}.  JOGL probes surfaceless contexts by asking EGL for window
 * configs, which Mesa's surfaceless platform does not have; the sticky quirk
 * {@code NoSurfacelessCtx} on the EGL factory's default device (unique id {@code .egl_nil_0}:
 * type EGL, no connection, unit 0), set before {@link GLProfile#initSingleton()}, makes it use a
 * pbuffer instead.
 */
public final class JoglContext implements AutoCloseable {
    private final GLAutoDrawable drawable;
    private final GLContext context;

    public JoglContext() {
        AbstractGraphicsDevice egl = new DefaultGraphicsDevice(NativeWindowFactory.TYPE_EGL, "nil", AbstractGraphicsDevice.DEFAULT_UNIT);
        GLRendererQuirks.addStickyDeviceQuirk(egl, GLRendererQuirks.NoSurfacelessCtx);
        GLProfile.initSingleton();
        GLProfile profile = GLProfile.get(GLProfile.GLES3);
        GLCapabilities caps = new GLCapabilities(profile);
        caps.setOnscreen(false);
        caps.setPBuffer(true);
        drawable = GLDrawableFactory.getFactory(profile).createOffscreenAutoDrawable(null, caps, null, 16, 16);
        drawable.display();
        context = drawable.getContext();
        if (context.makeCurrent() == GLContext.CONTEXT_NOT_CURRENT) {
            throw new IllegalStateException("the GLES context cannot be made current");
        }
    }

    public GL4ES3 gl() {
        return context.getGL().getGL4ES3();
    }

    @Override
    public void close() {
        context.release();
        drawable.destroy();
    }
}
