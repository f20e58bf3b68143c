/* spherecull — classifying raster/tracer disagreements: how far is a pixel
 * centre from the projected edges of the triangles in dispute?
 *
 * Pure double-precision geometry, no GL. */
#include <math.h>

#include "spherecull/sc_raster.h"
#include "raster_view.h"

static double segment_distance(double px, double py, const double a[2], const double b[2])
{
    double ux = b[0] - a[0], uy = b[1] - a[1];
    double wx = px - a[0], wy = py - a[1];
    double uu = ux * ux + uy * uy;
    double s = uu > 0 ? (wx * ux + wy * uy) / uu : 0;
    s = s < 0 ? 0 : s > 1 ? 1 : s;
    double dx = wx - s * ux, dy = wy - s * uy;
    return sqrt(dx * dx + dy * dy);
}

/* Distance from (px, py) to the outline of one triangle clipped at d >= dn. */
static double triangle_edge_distance(const sc_mesh_view *mesh, const sc_raster_view *view,
                                     double near_dist, uint32_t tri_index, double px, double py)
{
    const uint32_t *tri = sc_mesh_triangle(mesh, tri_index);
    double e[3][3];
    double dmax = -INFINITY;
    for (int i = 0; i < 3; i++) {
        sc_raster_to_eye(view, sc_mesh_vertex(mesh, tri[i]), e[i]);
        dmax = e[i][2] > dmax ? e[i][2] : dmax;
    }
    if (!(dmax > 0))
        return INFINITY;
    /* Without a near plane, clip just in front of the eye: the clip edge then
     * projects far off screen unless the triangle really passes the eye. */
    double dn = near_dist > 0 ? near_dist : dmax * 0x1p-40;
    /* Sutherland-Hodgman against one plane: at most 4 vertices remain. */
    double poly[4][3];
    int m = 0;
    for (int i = 0; i < 3; i++) {
        const double *p = e[i], *q = e[(i + 1) % 3];
        int pin = p[2] >= dn, qin = q[2] >= dn;
        if (pin) {
            for (int k = 0; k < 3; k++)
                poly[m][k] = p[k];
            m++;
        }
        if (pin != qin) {
            double s = (dn - p[2]) / (q[2] - p[2]);
            for (int k = 0; k < 2; k++)
                poly[m][k] = p[k] + s * (q[k] - p[k]);
            poly[m][2] = dn;
            m++;
        }
    }
    if (m < 3)
        return INFINITY;
    double scr[4][2];
    for (int i = 0; i < m; i++)
        sc_raster_project(view, poly[i], &scr[i][0], &scr[i][1]);
    double best = INFINITY;
    for (int i = 0; i < m; i++) {
        double dist = segment_distance(px, py, scr[i], scr[(i + 1) % m]);
        best = dist < best ? dist : best;
    }
    return best;
}

sc_status sc_raster_edge_distance(const sc_mesh_view *mesh, const sc_camera *cam,
                                  double near_dist, int x, int y,
                                  uint32_t id_a, uint32_t id_b, double *dist_px)
{
    if (!mesh || !cam || !dist_px || !(near_dist >= 0) || !isfinite(near_dist))
        return SC_ERR_INVALID_ARGUMENT;
    if (!sc_mesh_layout_ok(mesh) || (mesh->triangle_count && !mesh->indices) ||
        (mesh->vertex_count && !mesh->positions))
        return SC_ERR_INVALID_ARGUMENT;
    if (x < 0 || y < 0 || x >= cam->width || y >= cam->height ||
        id_a > mesh->triangle_count || id_b > mesh->triangle_count)
        return SC_ERR_INVALID_ARGUMENT;
    sc_raster_view view;
    sc_status st = sc_raster_view_make(cam, &view);
    if (st != SC_OK)
        return st;
    uint32_t ids[2] = { id_a, id_b };
    for (int k = 0; k < 2; k++) {
        if (!ids[k])
            continue;
        const uint32_t *tri = sc_mesh_triangle(mesh, ids[k] - 1);
        for (int i = 0; i < 3; i++) {
            if (tri[i] >= mesh->vertex_count)
                return SC_ERR_INVALID_ARGUMENT;
            const float *p = sc_mesh_vertex(mesh, tri[i]);
            if (!isfinite(p[0]) || !isfinite(p[1]) || !isfinite(p[2]))
                return SC_ERR_NONFINITE;
        }
    }
    double best = INFINITY;
    for (int k = 0; k < 2; k++) {
        if (!ids[k])
            continue;
        double dist = triangle_edge_distance(mesh, &view, near_dist, ids[k] - 1, x + 0.5, y + 0.5);
        best = dist < best ? dist : best;
    }
    *dist_px = best;
    return SC_OK;
}

const char *sc_raster_diff_name(sc_raster_diff kind)
{
    static const char *const names[SC_RASTER_DIFF_COUNT] = { "at-edge", "depth-tie", "elsewhere" };
    return (unsigned)kind < SC_RASTER_DIFF_COUNT ? names[kind] : "unknown";
}

/* Does the pixel-centre ray meet triangle index k (t > 0)? Double-precision
 * Moller-Trumbore: away from edges (the only case asked) rounding cannot
 * flip the answer. */
static int centre_ray_t(const sc_mesh_view *mesh, const sc_camera *cam, const sc_camera_frame *fr,
                        uint32_t k, int x, int y, double *t_out)
{
    double d[3], v[3][3], e1[3], e2[3], s[3], p[3], q[3];
    sc_camera_ray_dir(cam, fr, x + 0.5, y + 0.5, d);
    const uint32_t *tri = sc_mesh_triangle(mesh, k);
    for (int j = 0; j < 3; j++)
        for (int i = 0; i < 3; i++)
            v[j][i] = sc_mesh_vertex(mesh, tri[j])[i];
    for (int i = 0; i < 3; i++) {
        e1[i] = v[1][i] - v[0][i];
        e2[i] = v[2][i] - v[0][i];
        s[i] = cam->eye[i] - v[0][i];
    }
    p[0] = d[1] * e2[2] - d[2] * e2[1];
    p[1] = d[2] * e2[0] - d[0] * e2[2];
    p[2] = d[0] * e2[1] - d[1] * e2[0];
    double det = e1[0] * p[0] + e1[1] * p[1] + e1[2] * p[2];
    if (!(det != 0) || !isfinite(det))
        return 0;
    double u = (s[0] * p[0] + s[1] * p[1] + s[2] * p[2]) / det;
    q[0] = s[1] * e1[2] - s[2] * e1[1];
    q[1] = s[2] * e1[0] - s[0] * e1[2];
    q[2] = s[0] * e1[1] - s[1] * e1[0];
    double w = (d[0] * q[0] + d[1] * q[1] + d[2] * q[2]) / det;
    double t = (e2[0] * q[0] + e2[1] * q[1] + e2[2] * q[2]) / det;
    if (!(u >= 0 && w >= 0 && u + w <= 1 && t > 0))
        return 0;
    *t_out = t;
    return 1;
}

sc_status sc_raster_classify(const sc_mesh_view *mesh, const sc_camera *cam,
                             const sc_raster_image *img, int x, int y, uint32_t other_id,
                             sc_raster_diff *kind, double *edge_px)
{
    if (!cam || !img || !img->ids || !kind || img->width != cam->width ||
        img->height != cam->height || x < 0 || y < 0 || x >= img->width || y >= img->height)
        return SC_ERR_INVALID_ARGUMENT;
    uint32_t rid = img->ids[(size_t)y * (size_t)img->width + (size_t)x];
    if (rid == other_id)
        return SC_ERR_INVALID_ARGUMENT;
    double dist;
    sc_status st = sc_raster_edge_distance(mesh, cam, img->near_dist, x, y, rid, other_id, &dist);
    if (st != SC_OK)
        return st;
    if (edge_px)
        *edge_px = dist;
    if (dist <= SC_RASTER_EDGE_RADIUS_PX) {
        *kind = SC_RASTER_DIFF_AT_EDGE;
        return SC_OK;
    }
    *kind = SC_RASTER_DIFF_ELSEWHERE;
    if (rid == 0 || other_id == 0)
        return SC_OK;
    sc_camera_frame fr;
    if ((st = sc_camera_frame_make(cam, &fr)) != SC_OK)
        return st;
    double ta, tb;
    if (!centre_ray_t(mesh, cam, &fr, rid - 1, x, y, &ta) ||
        !centre_ray_t(mesh, cam, &fr, other_id - 1, x, y, &tb))
        return SC_OK;
    double t = ta < tb ? ta : tb;
    double tol = SC_RASTER_TIE_REL * t;
    if (img->depth_mode == SC_RASTER_DEPTH_FIXED24) {
        double n = img->near_dist, f = img->far_dist;
        tol += 16 * t * t * (f - n) / (f * n) * 0x1p-24;
    }
    if (fabs(ta - tb) <= tol)
        *kind = SC_RASTER_DIFF_DEPTH_TIE;
    return SC_OK;
}
