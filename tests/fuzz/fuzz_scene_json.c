/* libFuzzer target: scene descriptions (sc_scene_load_json_text).
 *
 * Any bytes: a status and one error line, or a scene that keeps every
 * invariant of scene_check.h. The caps are small so procedural meshes
 * named in the input stay cheap; relative paths and "cache:" resolve into
 * a directory that does not exist, so an input names real files only by
 * absolute path (those go through the isolated importer like any load). */
#include <stdint.h>
#include <string.h>

#include "scene_check.h"

#define FUZZ_MAX_TRIANGLES 20000

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    size_t warnings = 0;
    sc_scene_options o;
    sc_scene_options_init(&o);
    o.max_triangles = FUZZ_MAX_TRIANGLES;
    o.mesh_cache_dir = "/nonexistent/spherecull-fuzz-cache";
    o.import_timeout_ms = 5000;
    o.max_import_bytes = 256u << 20;
    o.warn = fz_on_warn;
    o.warn_ctx = &warnings;
    sc_scene *s = (sc_scene *)(uintptr_t)1;
    char err[256];
    sc_status st = sc_scene_load_json_text((const char *)data, size, "fuzz.json",
                                           "/nonexistent/spherecull-fuzz", &o, &s, err, sizeof err);
    fz_require((int)st >= 0 && st < SC_STATUS_COUNT);
    if (st == SC_OK) {
        fz_require(s != NULL);
        fz_check_scene(s, FUZZ_MAX_TRIANGLES);
        sc_scene_stats ss;
        sc_scene_get_stats(s, &ss);
        fz_require(warnings <= SC_SCENE_MAX_WARNINGS + 1 && warnings <= ss.warnings + 1);
        sc_scene_free(s);
    } else {
        fz_require(s == NULL);
        fz_check_error(err, sizeof err);
        /* No room for a message is allowed, and still no scene. */
        s = (sc_scene *)(uintptr_t)1;
        fz_require(sc_scene_load_json_text((const char *)data, size, NULL, "/nonexistent/spherecull-fuzz",
                                          &o, &s, NULL, 0) == st);
        fz_require(s == NULL);
    }
    return 0;
}
