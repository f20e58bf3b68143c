/* spherecull — the whole core library in one include.
 *
 *   #include <spherecull.h>
 *
 *   sc_bvh_config cfg;
 *   sc_bvh_config_default(&cfg);
 *   sc_bvh *bvh;
 *   sc_mesh_view mesh = { positions, nverts, indices, ntris, 0, 0 };   // strides 0: packed
 *   if (sc_bvh_build(&mesh, &cfg, &bvh) != SC_OK) ...
 *   sc_ray ray = { {0, 0, -5}, 0.0f, {0, 0, 1}, INFINITY };
 *   sc_hitrec hit;
 *   sc_trace_closest(bvh, &ray, &hit, NULL);
 *   sc_bvh_free(bvh);
 *
 * Link with spherecull::spherecull (CMake) or `pkg-config --libs spherecull`.
 * The core needs libc and libm only. The optional libraries have their own
 * headers, not included here: sc_scene.h (scene loading: assimp, cJSON),
 * sc_render.h and sc_image.h (rendering, PNG), sc_embree.h and sc_rtcray.h
 * (the Embree back end), sc_raster.h (the OSMesa raster reference).
 *
 * Threads: each header says what may run concurrently; in short, a built
 * sc_bvh is read-only and any number of threads may trace it at once.
 */
#ifndef SPHERECULL_H
#define SPHERECULL_H

#include "spherecull/sc_version.h"
#include "spherecull/sc_status.h"
#include "spherecull/sc_isa.h"
#include "spherecull/sc_ray.h"
#include "spherecull/sc_hit.h"
#include "spherecull/sc_mesh.h"
#include "spherecull/sc_circumsphere.h"
#include "spherecull/sc_prefilter.h"
#include "spherecull/sc_simd.h"
#include "spherecull/sc_bvh.h"
#include "spherecull/sc_trace.h"
#include "spherecull/sc_accel.h"
#include "spherecull/sc_camera.h"
#include "spherecull/sc_rays.h"

#endif
