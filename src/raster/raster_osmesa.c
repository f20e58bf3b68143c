/* spherecull — OSMesa raster reference: triangle IDs, depth and a preview.
 *
 * The CPU transforms every vertex to clip coordinates in double, relative to
 * the eye, and hands the GL ready-made (x, y, z, w) with identity matrices:
 * the GL's float vertex pipeline then only divides and maps to the viewport,
 * so a scene at 1e6 from the origin rasterizes as precisely as one at 0.
 */
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <GL/osmesa.h>
#include <GL/gl.h>
#include <GL/glext.h>

#include "spherecull/sc_raster.h"
#include "raster_view.h"

/* Triangles per glDrawArrays: bounds the expanded vertex arrays to ~1 MiB. */
enum { CHUNK_TRIANGLES = 1 << 14 };

static void set_error(sc_raster_image *out, const char *fmt, ...)
    __attribute__((format(printf, 2, 3)));

static void set_error(sc_raster_image *out, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(out->error, sizeof out->error, fmt, ap);
    va_end(ap);
}

void sc_raster_options_default(sc_raster_options *opt)
{
    if (!opt)
        return;
    memset(opt, 0, sizeof *opt);
    opt->depth_mode = SC_RASTER_DEPTH_AUTO;
    opt->background[0] = opt->background[1] = opt->background[2] = 40;
}

void sc_raster_image_free(sc_raster_image *img)
{
    if (!img)
        return;
    free(img->ids);
    free(img->depth);
    free(img->rgb);
    memset(img, 0, sizeof *img);
}

/* GL entry points past 1.1 come through OSMesaGetProcAddress, so nothing
 * depends on what libOSMesa happens to export. */
typedef struct gl_fbo_api {
    PFNGLGENFRAMEBUFFERSPROC GenFramebuffers;
    PFNGLBINDFRAMEBUFFERPROC BindFramebuffer;
    PFNGLDELETEFRAMEBUFFERSPROC DeleteFramebuffers;
    PFNGLGENRENDERBUFFERSPROC GenRenderbuffers;
    PFNGLBINDRENDERBUFFERPROC BindRenderbuffer;
    PFNGLDELETERENDERBUFFERSPROC DeleteRenderbuffers;
    PFNGLRENDERBUFFERSTORAGEPROC RenderbufferStorage;
    PFNGLFRAMEBUFFERRENDERBUFFERPROC FramebufferRenderbuffer;
    PFNGLCHECKFRAMEBUFFERSTATUSPROC CheckFramebufferStatus;
    PFNGLCLIPCONTROLPROC ClipControl;
} gl_fbo_api;

static int gl_version_at_least(int major, int minor)
{
    const char *v = (const char *)glGetString(GL_VERSION);
    int ma = 0, mi = 0;
    if (!v || sscanf(v, "%d.%d", &ma, &mi) != 2)
        return 0;
    return ma > major || (ma == major && mi >= minor);
}

static int gl_has_extension(const char *name)
{
    const char *ext = (const char *)glGetString(GL_EXTENSIONS);
    size_t n = strlen(name);
    for (const char *p = ext; p && (p = strstr(p, name)) != NULL; p += n)
        if ((p == ext || p[-1] == ' ') && (p[n] == ' ' || p[n] == '\0'))
            return 1;
    return 0;
}

/* OSMESAproc is unprototyped; going through void (*)(void), the generic
 * function pointer, is the conversion -Wcast-function-type accepts. */
static int load_fbo_api(gl_fbo_api *api)
{
#define LOAD(field, name)                                              \
    api->field = (__typeof__(api->field))(void (*)(void))OSMesaGetProcAddress(name); \
    if (!api->field)                                                   \
        return 0;
    LOAD(GenFramebuffers, "glGenFramebuffers")
    LOAD(BindFramebuffer, "glBindFramebuffer")
    LOAD(DeleteFramebuffers, "glDeleteFramebuffers")
    LOAD(GenRenderbuffers, "glGenRenderbuffers")
    LOAD(BindRenderbuffer, "glBindRenderbuffer")
    LOAD(DeleteRenderbuffers, "glDeleteRenderbuffers")
    LOAD(RenderbufferStorage, "glRenderbufferStorage")
    LOAD(FramebufferRenderbuffer, "glFramebufferRenderbuffer")
    LOAD(CheckFramebufferStatus, "glCheckFramebufferStatus")
    LOAD(ClipControl, "glClipControl")
#undef LOAD
    return gl_version_at_least(4, 5) || gl_has_extension("GL_ARB_clip_control");
}

static sc_status gl_status(sc_raster_image *out, const char *where)
{
    GLenum e = glGetError();
    if (e == GL_NO_ERROR)
        return SC_OK;
    set_error(out, "GL error 0x%04x during %s", (unsigned)e, where);
    return e == GL_OUT_OF_MEMORY ? SC_ERR_OUT_OF_MEMORY : SC_ERR_UNSUPPORTED;
}

/* Everything one render needs once inputs are validated. */
typedef struct raster_job {
    const sc_mesh_view *mesh;
    const sc_raster_view *view;
    const double *d;             /* per vertex: eye-space depth */
    double near_dist, far_dist;
    sc_raster_depth_mode mode;
    int width, height;
} raster_job;

/* Clip coordinates of one vertex. x and y are scaled so that the frustum is
 * the unit cube; z follows the depth mode. */
static void clip_coords(const raster_job *job, uint32_t vi, float out[4])
{
    double e[3];
    sc_raster_to_eye(job->view, sc_mesh_vertex(job->mesh, vi), e);
    double d = e[2], n = job->near_dist, f = job->far_dist;
    out[0] = (float)(e[0] / job->view->frame.half_w);
    out[1] = (float)(e[1] / job->view->frame.half_h);
    if (job->mode == SC_RASTER_DEPTH_FLOAT_REVERSED)
        out[2] = (float)n;       /* z_ndc = n/d in [0, 1], clipped where d < n */
    else
        out[2] = (float)(((f + n) * d - 2 * f * n) / (f - n));
    out[3] = (float)d;
}

static sc_status draw_triangles(const raster_job *job, sc_raster_image *out)
{
    size_t nt = job->mesh->triangle_count;
    size_t chunk = nt < CHUNK_TRIANGLES ? nt : CHUNK_TRIANGLES;
    if (chunk == 0)
        return SC_OK;
    float *vbuf = malloc(chunk * 3 * 4 * sizeof *vbuf);
    GLubyte *cbuf = malloc(chunk * 3 * 4);
    if (!vbuf || !cbuf) {
        free(vbuf);
        free(cbuf);
        set_error(out, "out of memory for vertex arrays");
        return SC_ERR_OUT_OF_MEMORY;
    }
    glEnableClientState(GL_VERTEX_ARRAY);
    glEnableClientState(GL_COLOR_ARRAY);
    glVertexPointer(4, GL_FLOAT, 0, vbuf);
    glColorPointer(4, GL_UNSIGNED_BYTE, 0, cbuf);
    for (size_t t0 = 0; t0 < nt; t0 += chunk) {
        size_t k = nt - t0 < chunk ? nt - t0 : chunk;
        size_t m = 0;
        for (size_t t = t0; t < t0 + k; t++) {
            const uint32_t *tri = sc_mesh_triangle(job->mesh, t);
            /* Triangles wholly behind the near plane cannot show; skipping
             * them keeps the clipper's work proportional to what is visible. */
            double n = job->near_dist;
            if (job->d[tri[0]] < n && job->d[tri[1]] < n && job->d[tri[2]] < n)
                continue;
            uint32_t id = (uint32_t)(t + 1);
            for (int j = 0; j < 3; j++, m++) {
                clip_coords(job, tri[j], vbuf + 4 * m);
                cbuf[4 * m + 0] = (GLubyte)(id & 0xff);
                cbuf[4 * m + 1] = (GLubyte)((id >> 8) & 0xff);
                cbuf[4 * m + 2] = (GLubyte)((id >> 16) & 0xff);
                cbuf[4 * m + 3] = (GLubyte)(id >> 24);
            }
        }
        if (m)
            glDrawArrays(GL_TRIANGLES, 0, (GLsizei)m);
    }
    glDisableClientState(GL_COLOR_ARRAY);
    glDisableClientState(GL_VERTEX_ARRAY);
    glFinish();
    free(vbuf);
    free(cbuf);
    return gl_status(out, "drawing");
}

/* Fixed-function state for exact colour transfer: every fragment's colour
 * must be the ID bytes, untouched. */
static void setup_state(const raster_job *job)
{
    glViewport(0, 0, job->width, job->height);
    glMatrixMode(GL_PROJECTION);
    glLoadIdentity();
    glMatrixMode(GL_MODELVIEW);
    glLoadIdentity();
    glDisable(GL_LIGHTING);
    glDisable(GL_BLEND);
    glDisable(GL_DITHER);
    glDisable(GL_MULTISAMPLE);
    glDisable(GL_CULL_FACE);
    glDisable(GL_ALPHA_TEST);
    glDisable(GL_FOG);
    glDisable(GL_TEXTURE_2D);
    glDisable(GL_POLYGON_SMOOTH);
    glDisable(GL_SCISSOR_TEST);
    glPolygonMode(GL_FRONT_AND_BACK, GL_FILL);
    glShadeModel(GL_FLAT);
    glColorMask(GL_TRUE, GL_TRUE, GL_TRUE, GL_TRUE);
    glDepthMask(GL_TRUE);
    glEnable(GL_DEPTH_TEST);
    glClearColor(0, 0, 0, 0);
    if (job->mode == SC_RASTER_DEPTH_FLOAT_REVERSED) {
        glDepthFunc(GL_GREATER);
        glClearDepth(0.0);
    } else {
        glDepthFunc(GL_LESS);
        glClearDepth(1.0);
    }
    glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
    glPixelStorei(GL_PACK_ALIGNMENT, 1);
}

/* GL rows run bottom-up; the image runs top-down. */
static sc_status read_back(const raster_job *job, GLubyte *rgba, void *zbuf, sc_raster_image *out)
{
    int w = job->width, h = job->height;
    glReadPixels(0, 0, w, h, GL_RGBA, GL_UNSIGNED_BYTE, rgba);
    if (job->mode == SC_RASTER_DEPTH_FLOAT_REVERSED)
        glReadPixels(0, 0, w, h, GL_DEPTH_COMPONENT, GL_FLOAT, zbuf);
    else
        glReadPixels(0, 0, w, h, GL_DEPTH_COMPONENT, GL_UNSIGNED_INT, zbuf);
    sc_status st = gl_status(out, "read-back");
    if (st != SC_OK)
        return st;
    double n = job->near_dist, f = job->far_dist;
    for (int r = 0; r < h; r++) {
        size_t src = (size_t)r * (size_t)w;
        size_t dst = (size_t)(h - 1 - r) * (size_t)w;
        for (int x = 0; x < w; x++) {
            const GLubyte *c = rgba + 4 * (src + (size_t)x);
            uint32_t id = (uint32_t)c[0] | (uint32_t)c[1] << 8 | (uint32_t)c[2] << 16 |
                          (uint32_t)c[3] << 24;
            if (id > job->mesh->triangle_count) {
                set_error(out, "the rasterizer altered an ID colour (pixel %d,%d holds %u)",
                          x, h - 1 - r, (unsigned)id);
                return SC_ERR_UNSUPPORTED;
            }
            out->ids[dst + (size_t)x] = id;
            double t = INFINITY;
            if (id != 0) {
                if (job->mode == SC_RASTER_DEPTH_FLOAT_REVERSED) {
                    double z = ((const float *)zbuf)[src + (size_t)x];
                    t = n / z;
                } else {
                    double z = ((const GLuint *)zbuf)[src + (size_t)x] / 4294967295.0;
                    t = f * n / (f - z * (f - n));
                }
            }
            out->depth[dst + (size_t)x] = (float)t;
        }
    }
    return SC_OK;
}

/* Sets up an FBO with a float depth buffer and 0..1 clip depth. Returns 0 if
 * this GL cannot, leaving no error pending. */
static int setup_float_target(const raster_job *job, gl_fbo_api *api, GLuint *fbo, GLuint rbo[2])
{
    if (!load_fbo_api(api))
        return 0;
    GLint maxrb = 0;
    glGetIntegerv(GL_MAX_RENDERBUFFER_SIZE, &maxrb);
    if (glGetError() != GL_NO_ERROR || maxrb < job->width || maxrb < job->height)
        return 0;
    api->GenFramebuffers(1, fbo);
    api->BindFramebuffer(GL_FRAMEBUFFER, *fbo);
    api->GenRenderbuffers(2, rbo);
    api->BindRenderbuffer(GL_RENDERBUFFER, rbo[0]);
    api->RenderbufferStorage(GL_RENDERBUFFER, GL_RGBA8, job->width, job->height);
    api->BindRenderbuffer(GL_RENDERBUFFER, rbo[1]);
    api->RenderbufferStorage(GL_RENDERBUFFER, GL_DEPTH_COMPONENT32F, job->width, job->height);
    api->FramebufferRenderbuffer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, rbo[0]);
    api->FramebufferRenderbuffer(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, rbo[1]);
    int ok = api->CheckFramebufferStatus(GL_FRAMEBUFFER) == GL_FRAMEBUFFER_COMPLETE;
    if (ok) {
        api->ClipControl(GL_LOWER_LEFT, GL_ZERO_TO_ONE);
        GLint bits = 0;
        glGetIntegerv(GL_DEPTH_BITS, &bits);
        ok = bits >= 32;
    }
    if (glGetError() != GL_NO_ERROR)
        ok = 0;
    if (!ok) {
        api->BindFramebuffer(GL_FRAMEBUFFER, 0);
        api->DeleteRenderbuffers(2, rbo);
        api->DeleteFramebuffers(1, fbo);
        *fbo = 0;
        while (glGetError() != GL_NO_ERROR) {
        }
    }
    return ok;
}

static void choose_clip(const raster_job *job, const sc_raster_options *opt,
                        sc_raster_depth_mode mode, double *near_out, double *far_out);

/* Creates the context, settles the depth mode (AUTO: float if this GL can),
 * picks near/far for it, draws and reads back. */
static sc_status gl_render(raster_job *job, const sc_raster_options *opt, sc_raster_image *out)
{
    size_t npix = (size_t)job->width * (size_t)job->height;
    GLubyte *rgba = malloc(npix * 4);
    void *zbuf = malloc(npix * 4);
    GLubyte *fixed_fb = NULL;
    GLubyte dummy[4];
    gl_fbo_api api = { 0 };
    GLuint fbo = 0, rbo[2] = { 0, 0 };
    sc_status st = SC_OK;
    OSMesaContext ctx = NULL;
    if (!rgba || !zbuf) {
        set_error(out, "out of memory for %dx%d read-back buffers", job->width, job->height);
        st = SC_ERR_OUT_OF_MEMORY;
        goto done;
    }
    /* The default framebuffer carries the 24-bit depth buffer of FIXED24;
     * FLOAT_REVERSED draws into an FBO and leaves it 1x1. */
    ctx = OSMesaCreateContextExt(OSMESA_RGBA, 24, 0, 0, NULL);
    if (!ctx) {
        set_error(out, "OSMesa could not create a context");
        st = SC_ERR_UNSUPPORTED;
        goto done;
    }
    if (!OSMesaMakeCurrent(ctx, dummy, GL_UNSIGNED_BYTE, 1, 1)) {
        set_error(out, "OSMesa could not make its context current");
        st = SC_ERR_UNSUPPORTED;
        goto done;
    }
    GLint maxvp[2] = { 0, 0 };
    glGetIntegerv(GL_MAX_VIEWPORT_DIMS, maxvp);
    if (job->width > maxvp[0] || job->height > maxvp[1]) {
        set_error(out, "image %dx%d exceeds this GL's maximum viewport %dx%d",
                  job->width, job->height, (int)maxvp[0], (int)maxvp[1]);
        st = SC_ERR_LIMIT;
        goto done;
    }
    job->mode = SC_RASTER_DEPTH_FIXED24;
    if (opt->depth_mode != SC_RASTER_DEPTH_FIXED24) {
        if (setup_float_target(job, &api, &fbo, rbo)) {
            job->mode = SC_RASTER_DEPTH_FLOAT_REVERSED;
        } else if (opt->depth_mode == SC_RASTER_DEPTH_FLOAT_REVERSED) {
            set_error(out, "this GL (%s) offers no float depth buffer with clip control",
                      (const char *)glGetString(GL_VERSION));
            st = SC_ERR_UNSUPPORTED;
            goto done;
        }
    }
    if (job->mode == SC_RASTER_DEPTH_FIXED24) {
        GLint maxw = 0, maxh = 0;
        OSMesaGetIntegerv(OSMESA_MAX_WIDTH, &maxw);
        OSMesaGetIntegerv(OSMESA_MAX_HEIGHT, &maxh);
        if (job->width > maxw || job->height > maxh) {
            set_error(out, "image %dx%d exceeds OSMesa's maximum %dx%d",
                      job->width, job->height, (int)maxw, (int)maxh);
            st = SC_ERR_LIMIT;
            goto done;
        }
        fixed_fb = malloc(npix * 4);
        if (!fixed_fb) {
            set_error(out, "out of memory for a %dx%d framebuffer", job->width, job->height);
            st = SC_ERR_OUT_OF_MEMORY;
            goto done;
        }
        if (!OSMesaMakeCurrent(ctx, fixed_fb, GL_UNSIGNED_BYTE, job->width, job->height)) {
            set_error(out, "OSMesa could not bind a %dx%d buffer", job->width, job->height);
            st = SC_ERR_UNSUPPORTED;
            goto done;
        }
    }
    GLint bits = 0;
    glGetIntegerv(GL_DEPTH_BITS, &bits);
    out->depth_bits = bits;
    if (job->mode == SC_RASTER_DEPTH_FIXED24 && bits < 24) {
        set_error(out, "OSMesa gave a %d-bit depth buffer, 24 needed", (int)bits);
        st = SC_ERR_UNSUPPORTED;
        goto done;
    }
    choose_clip(job, opt, job->mode, &job->near_dist, &job->far_dist);
    setup_state(job);
    st = gl_status(out, "state set-up");
    if (st == SC_OK)
        st = draw_triangles(job, out);
    if (st == SC_OK)
        st = read_back(job, rgba, zbuf, out);
done:
    if (fbo) {
        api.BindFramebuffer(GL_FRAMEBUFFER, 0);
        api.DeleteRenderbuffers(2, rbo);
        api.DeleteFramebuffers(1, &fbo);
    }
    if (ctx) {
        OSMesaMakeCurrent(NULL, NULL, 0, 0, 0);
        OSMesaDestroyContext(ctx);
    }
    free(fixed_fb);
    free(rgba);
    free(zbuf);
    return st;
}

/* The preview shades from the ID buffer: flat per-face lighting is a
 * function of the visible triangle alone, so this equals a second lit GL
 * pass with the same visibility, at no extra raster cost. */
static void shade_preview(const sc_mesh_view *mesh, const sc_raster_view *view,
                          const sc_camera *cam, const sc_raster_options *opt,
                          sc_raster_image *out)
{
    const sc_camera_frame *fr = &view->frame;
    double L[3];
    double ll = 0;
    for (int i = 0; i < 3; i++) {
        L[i] = opt->light_dir[i];
        ll += L[i] * L[i];
    }
    if (!(ll > 0) || !isfinite(ll)) {
        ll = 0;
        for (int i = 0; i < 3; i++) {
            L[i] = -fr->forward[i] + 0.6 * fr->up[i] + 0.35 * fr->right[i];
            ll += L[i] * L[i];
        }
    }
    ll = sqrt(ll);
    for (int i = 0; i < 3; i++)
        L[i] /= ll;
    for (int y = 0; y < out->height; y++) {
        for (int x = 0; x < out->width; x++) {
            size_t p = (size_t)y * (size_t)out->width + (size_t)x;
            uint8_t *o = out->rgb + 3 * p;
            uint32_t id = out->ids[p];
            if (id == 0) {
                memcpy(o, opt->background, 3);
                continue;
            }
            const uint32_t *tri = sc_mesh_triangle(mesh, id - 1);
            const float *a = sc_mesh_vertex(mesh, tri[0]);
            const float *b = sc_mesh_vertex(mesh, tri[1]);
            const float *c = sc_mesh_vertex(mesh, tri[2]);
            double u[3], v[3], nrm[3], dir[3];
            for (int i = 0; i < 3; i++) {
                u[i] = (double)b[i] - a[i];
                v[i] = (double)c[i] - a[i];
            }
            nrm[0] = u[1] * v[2] - u[2] * v[1];
            nrm[1] = u[2] * v[0] - u[0] * v[2];
            nrm[2] = u[0] * v[1] - u[1] * v[0];
            double nl = sqrt(nrm[0] * nrm[0] + nrm[1] * nrm[1] + nrm[2] * nrm[2]);
            double lambert = 0.5;
            if (nl > 0 && isfinite(nl)) {
                sc_camera_ray_dir(cam, fr, x + 0.5, y + 0.5, dir);
                double facing = nrm[0] * dir[0] + nrm[1] * dir[1] + nrm[2] * dir[2];
                double s = facing > 0 ? -1 / nl : 1 / nl;
                double nd = s * (nrm[0] * L[0] + nrm[1] * L[1] + nrm[2] * L[2]);
                lambert = nd > 0 ? nd : 0;
            }
            double shade = 0.15 + 0.85 * lambert;
            for (int i = 0; i < 3; i++) {
                double base = opt->colors ? opt->colors[3 * (size_t)(id - 1) + i] : 0.8;
                double val = base * shade * 255 + 0.5;
                o[i] = (uint8_t)(val < 0 ? 0 : val > 255 ? 255 : val);
            }
        }
    }
}

static sc_status validate(const sc_mesh_view *mesh, const sc_camera *cam,
                          const sc_raster_options *opt, sc_raster_image *out)
{
    if (!mesh || !cam) {
        set_error(out, "NULL mesh or camera");
        return SC_ERR_INVALID_ARGUMENT;
    }
    if (!sc_mesh_layout_ok(mesh)) {
        set_error(out, "mesh strides must be 0 or multiples of 4 from 12, arrays 4-byte aligned");
        return SC_ERR_INVALID_ARGUMENT;
    }
    if ((mesh->vertex_count && !mesh->positions) || (mesh->triangle_count && !mesh->indices)) {
        set_error(out, "mesh has counts but no arrays");
        return SC_ERR_INVALID_ARGUMENT;
    }
    if (mesh->triangle_count >= UINT32_MAX || mesh->vertex_count > SIZE_MAX / 24 ||
        mesh->triangle_count > SIZE_MAX / 48) {
        set_error(out, "%zu triangles: IDs are 32-bit, at most %u triangles",
                  mesh->triangle_count, (unsigned)(UINT32_MAX - 1));
        return SC_ERR_LIMIT;
    }
    if ((unsigned)opt->depth_mode >= SC_RASTER_DEPTH_MODE_COUNT) {
        set_error(out, "unknown depth mode %d", (int)opt->depth_mode);
        return SC_ERR_INVALID_ARGUMENT;
    }
    if (!(opt->near_dist >= 0) || !isfinite(opt->near_dist) || !(opt->far_dist >= 0) ||
        (opt->near_dist > 0 && opt->far_dist > 0 && !(opt->far_dist > opt->near_dist))) {
        set_error(out, "near/far must be finite, non-negative, near < far");
        return SC_ERR_INVALID_ARGUMENT;
    }
    if (cam->width < 1 || cam->height < 1 || cam->width > 65536 || cam->height > 65536) {
        set_error(out, "image size %dx%d out of range", cam->width, cam->height);
        return cam->width < 1 || cam->height < 1 ? SC_ERR_INVALID_ARGUMENT : SC_ERR_LIMIT;
    }
    for (size_t i = 0; i < mesh->vertex_count; i++) {
        const float *p = sc_mesh_vertex(mesh, i);
        if (!isfinite(p[0]) || !isfinite(p[1]) || !isfinite(p[2])) {
            set_error(out, "vertex %zu has a non-finite coordinate", i);
            return SC_ERR_NONFINITE;
        }
    }
    for (size_t t = 0; t < mesh->triangle_count; t++)
        for (int c = 0; c < 3; c++)
            if (sc_mesh_triangle(mesh, t)[c] >= mesh->vertex_count) {
                set_error(out, "triangle %zu refers to vertex %u of %zu", t,
                          (unsigned)sc_mesh_triangle(mesh, t)[c], mesh->vertex_count);
                return SC_ERR_INVALID_ARGUMENT;
            }
    return SC_OK;
}

/* Near/far from the vertices that triangles use. Near sits a hair below the
 * nearest vertex so nothing in front of the camera is clipped; when a
 * triangle reaches behind the eye it must be clipped somewhere, and a tiny
 * fraction of far loses only what lies within that distance of the eye. */
static void choose_clip(const raster_job *job, const sc_raster_options *opt,
                        sc_raster_depth_mode mode, double *near_out, double *far_out)
{
    double dmin = INFINITY, dmax = -INFINITY;
    int behind = 0;
    for (size_t i = 0; i < 3 * job->mesh->triangle_count; i++) {
        double d = job->d[sc_mesh_triangle(job->mesh, i / 3)[i % 3]];
        if (d > 0) {
            dmin = d < dmin ? d : dmin;
            dmax = d > dmax ? d : dmax;
        } else {
            behind = 1;
        }
    }
    if (!(dmax > 0)) {           /* nothing in front: any valid pair will do */
        dmin = 1;
        dmax = 2;
    }
    double f = dmax * (1 + 0x1p-10);
    /* FIXED24 trades range for resolution: its relative resolution at far
     * is (far/near) * 2^-24, so near may not go below far * 2^-14. */
    double floor_ratio = mode == SC_RASTER_DEPTH_FIXED24 ? 0x1p-14 : 0x1p-40;
    double n = behind ? f * floor_ratio : dmin * (1 - 0x1p-10);
    if (n < f * floor_ratio)
        n = f * floor_ratio;
    if (opt->near_dist > 0)
        n = opt->near_dist;
    if (opt->far_dist > 0)
        f = opt->far_dist;
    if (!(f > n))
        f = n * 2;
    *near_out = n;
    *far_out = f;
}

sc_status sc_raster_render(const sc_mesh_view *mesh, const sc_camera *cam,
                           const sc_raster_options *opt_in, sc_raster_image *out)
{
    if (!out)
        return SC_ERR_INVALID_ARGUMENT;
    memset(out, 0, sizeof *out);
    sc_raster_options opt;
    if (opt_in)
        opt = *opt_in;
    else
        sc_raster_options_default(&opt);
    sc_status st = validate(mesh, cam, &opt, out);
    if (st != SC_OK)
        return st;
    sc_raster_view view;
    st = sc_raster_view_make(cam, &view);
    if (st != SC_OK) {
        set_error(out, "invalid camera (view direction, up vector, fov or size)");
        return st;
    }
    size_t npix = (size_t)cam->width * (size_t)cam->height;
    double *d = malloc((mesh->vertex_count ? mesh->vertex_count : 1) * sizeof *d);
    out->ids = malloc(npix * sizeof *out->ids);
    out->depth = malloc(npix * sizeof *out->depth);
    out->rgb = malloc(npix * 3);
    if (!d || !out->ids || !out->depth || !out->rgb) {
        free(d);
        sc_raster_image_free(out);
        set_error(out, "out of memory for a %dx%d image", cam->width, cam->height);
        return SC_ERR_OUT_OF_MEMORY;
    }
    out->width = cam->width;
    out->height = cam->height;
    for (size_t i = 0; i < mesh->vertex_count; i++) {
        double e[3];
        sc_raster_to_eye(&view, sc_mesh_vertex(mesh, i), e);
        d[i] = e[2];
    }
    raster_job job = { .mesh = mesh, .view = &view, .d = d,
                       .width = cam->width, .height = cam->height };
    st = gl_render(&job, &opt, out);
    free(d);
    if (st != SC_OK) {
        char msg[sizeof out->error];
        memcpy(msg, out->error, sizeof msg);
        sc_raster_image_free(out);
        memcpy(out->error, msg, sizeof msg);
        return st;
    }
    out->depth_mode = job.mode;
    out->near_dist = job.near_dist;
    out->far_dist = job.mode == SC_RASTER_DEPTH_FLOAT_REVERSED ? INFINITY : job.far_dist;
    shade_preview(mesh, &view, cam, &opt, out);
    return SC_OK;
}
