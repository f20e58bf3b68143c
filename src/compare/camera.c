#include <math.h>

#include "spherecull/sc_camera.h"

static double norm3(const double v[3])
{
    return sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
}

static void cross3(double o[3], const double a[3], const double b[3])
{
    o[0] = a[1] * b[2] - a[2] * b[1];
    o[1] = a[2] * b[0] - a[0] * b[2];
    o[2] = a[0] * b[1] - a[1] * b[0];
}

sc_status sc_camera_frame_make(const sc_camera *cam, sc_camera_frame *f)
{
    if (!cam || !f || !(cam->fov_y_deg > 0 && cam->fov_y_deg < 180) ||
        cam->width < 1 || cam->height < 1)
        return SC_ERR_INVALID_ARGUMENT;
    double fwd[3];
    for (int i = 0; i < 3; i++) {
        fwd[i] = cam->target[i] - cam->eye[i];
        if (!isfinite(fwd[i]) || !isfinite(cam->up[i]))
            return SC_ERR_INVALID_ARGUMENT;
    }
    double lf = norm3(fwd);
    if (!(lf > 0) || !isfinite(lf))
        return SC_ERR_INVALID_ARGUMENT;
    for (int i = 0; i < 3; i++)
        f->forward[i] = fwd[i] / lf;
    cross3(f->right, f->forward, cam->up);
    double lr = norm3(f->right);
    if (!(lr > 1e-12 * norm3(cam->up)) || !isfinite(lr))
        return SC_ERR_INVALID_ARGUMENT;
    for (int i = 0; i < 3; i++)
        f->right[i] /= lr;
    cross3(f->up, f->right, f->forward);
    f->half_h = tan(cam->fov_y_deg * (3.14159265358979323846 / 360.0));
    f->half_w = f->half_h * (double)cam->width / (double)cam->height;
    return SC_OK;
}

void sc_camera_ray_dir(const sc_camera *cam, const sc_camera_frame *f,
                       double px, double py, double dir[3])
{
    double sx = (2 * px / cam->width - 1) * f->half_w;
    double sy = (1 - 2 * py / cam->height) * f->half_h;
    for (int i = 0; i < 3; i++)
        dir[i] = f->forward[i] + sx * f->right[i] + sy * f->up[i];
}
