/* sc_scene_load: which loader reads which spec. The one file that knows
 * every loader: mesh files go to assimp (in this process or in a child,
 * chosen here), "proc:" to the generators, "*.json" to the scene-file
 * reader; the JSON reader and proc:grid get append_spec back as a callback
 * for the meshes they name. */
#define _POSIX_C_SOURCE 200809L
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>

#include "load_assimp.h"
#include "load_json.h"
#include "procedural.h"
#include "scene_container.h"

sc_status sc_scene_mesh_cache_dir(const sc_scene_options *o, char *buf, size_t len)
{
    if (!buf || len == 0)
        return SC_ERR_INVALID_ARGUMENT;
    const char *dir = o ? o->mesh_cache_dir : NULL;
    const char *env;
    int n;
    if (dir && *dir)
        n = snprintf(buf, len, "%s", dir);
    else if ((env = getenv("SPHERECULL_MESHES")) && *env)
        n = snprintf(buf, len, "%s", env);
    else if ((env = getenv("XDG_CACHE_HOME")) && *env)
        n = snprintf(buf, len, "%s/spherecull/meshes", env);
    else if ((env = getenv("HOME")) && *env)
        n = snprintf(buf, len, "%s/.cache/spherecull/meshes", env);
    else
        return SC_ERR_IO;
    return n >= 0 && (size_t)n < len ? SC_OK : SC_ERR_RANGE;
}


static int has_suffix_ci(const char *s, const char *suffix)
{
    size_t n = strlen(s), m = strlen(suffix);
    return n >= m && strcasecmp(s + n - m, suffix) == 0;
}

static char *str_replace_all(const char *s, const char *what, const char *with)
{
    size_t lw = strlen(what), lr = strlen(with), count = 0;
    for (const char *p = strstr(s, what); p; p = strstr(p + lw, what))
        count++;
    size_t len = strlen(s) + count * lr + 1;
    char *out = malloc(len);
    if (!out)
        return NULL;
    char *o = out;
    const char *p = s, *q;
    while ((q = strstr(p, what))) {
        memcpy(o, p, (size_t)(q - p));
        o += q - p;
        memcpy(o, with, lr);
        o += lr;
        p = q + lw;
    }
    strcpy(o, p);
    return out;
}

/* Expands "cache:NAME" and "${SPHERECULL_MESHES}", and joins a relative
 * path to base_dir, into a malloc'd path. */
static sc_status expand_path(sc_scene *s, const char *spec, const char *base_dir, char **out,
                             char *err, size_t errlen)
{
    *out = NULL;
    int is_cache = strncmp(spec, "cache:", 6) == 0;
    char cache[4096];
    if (is_cache || strstr(spec, "${SPHERECULL_MESHES}")) {
        sc_scene_options o;
        sc_scene_options_init(&o);
        o.mesh_cache_dir = s->cache_dir;
        sc_status st = sc_scene_mesh_cache_dir(&o, cache, sizeof cache);
        if (st != SC_OK)
            return sc_scene_errf(err, errlen, SC_ERR_IO,
                                 "%s: cannot locate the mesh cache (set SPHERECULL_MESHES or HOME)", spec);
    }
    char *p;
    if (is_cache) {
        const char *name = spec + 6;
        if (!*name)
            return sc_scene_errf(err, errlen, SC_ERR_PARSE, "'cache:' needs a file name");
        size_t len = strlen(cache) + strlen(name) + 2;
        p = malloc(len);
        if (p)
            snprintf(p, len, "%s/%s", cache, name);
    } else if (strstr(spec, "${SPHERECULL_MESHES}")) {
        p = str_replace_all(spec, "${SPHERECULL_MESHES}", cache);
    } else if (spec[0] != '/' && base_dir && *base_dir) {
        size_t len = strlen(base_dir) + strlen(spec) + 2;
        p = malloc(len);
        if (p)
            snprintf(p, len, "%s/%s", base_dir, spec);
    } else {
        p = strdup(spec);
    }
    if (!p)
        return sc_scene_errf(err, errlen, SC_ERR_OUT_OF_MEMORY, "out of memory");
    *out = p;
    return SC_OK;
}

/* Mesh files: the cheap checks first, in this process, so the common
 * mistakes (missing file, directory, empty file) cost no fork and give the
 * precise message; then the import, in a child process unless the options
 * ask for this one (see sc_scene_options). */
static sc_status load_mesh_file(sc_scene *s, const char *path, const double xform[16],
                                const float *color, char *err, size_t errlen)
{
    sc_status st = sc_scene_check_mesh_file(path, err, errlen);
    if (st != SC_OK)
        return st;
    if (s->import_in_process)
        return sc_scene_import_assimp(s, path, xform, color, 1, err, errlen);
    return sc_scene_import_assimp_in_child(s, path, xform, color, err, errlen);
}

static sc_status append_spec(sc_scene *s, const char *spec, const char *base_dir,
                             const double xform[16], const float *color, char *err, size_t errlen)
{
    if (strncmp(spec, "proc:", 5) == 0)
        return sc_scene_load_procedural(s, spec, xform, color, append_spec, err, errlen);
    char *path;
    sc_status st = expand_path(s, spec, base_dir, &path, err, errlen);
    if (st != SC_OK)
        return st;
    if (has_suffix_ci(path, ".json")) {
        /* A scene file names its meshes relative to itself: say which file. */
        st = sc_scene_errf(err, errlen, SC_ERR_PARSE, "%s: a scene file cannot be used as a mesh",
                           base_dir && strncmp(spec, "cache:", 6) != 0 ? path : spec);
        free(path);
        return st;
    }
    struct stat sb;
    if (strncmp(spec, "cache:", 6) == 0 && stat(path, &sb) != 0) {
        st = sc_scene_errf(err, errlen, SC_ERR_IO,
                           "%s: %s not found (run scripts/fetch-meshes.sh to fill the mesh cache)",
                           spec, path);
        free(path);
        return st;
    }
    st = load_mesh_file(s, path, xform, color, err, errlen);
    free(path);
    return st;
}

/* The common end of every load: a scene without triangles is an error,
 * mesh files get an automatic camera and light, warnings beyond the limit
 * are summarised. Frees s on failure. */
static sc_status finish_load(sc_scene *s, sc_status st, const char *spec, int json,
                             sc_scene **out, char *err, size_t errlen)
{
    if (st == SC_OK && s->num_triangles == 0)
        st = sc_scene_errf(err, errlen, SC_ERR_PARSE, "%s: no triangles to render", spec);
    if (st == SC_OK && !json) {
        st = sc_scene_frame_camera(s, 35, 25, 40, SC_SCENE_DEFAULT_WIDTH, SC_SCENE_DEFAULT_HEIGHT);
        if (st == SC_OK)
            st = sc_scene_add_default_light(s);
        if (st != SC_OK)
            st = sc_scene_errf(err, errlen, st, "%s: cannot frame the camera on the model", spec);
    }
    if (st != SC_OK) {
        sc_scene_free(s);
        return st;
    }
    if (s->warnings > SC_SCENE_MAX_WARNINGS && s->warn) {
        char buf[96];
        snprintf(buf, sizeof buf, "%zu more warnings not shown",
                 s->warnings - SC_SCENE_MAX_WARNINGS);
        s->warn(s->warn_ctx, buf);
    }
    *out = s;
    return SC_OK;
}

sc_status sc_scene_load(const char *spec, const sc_scene_options *options, sc_scene **out,
                        char *err, size_t errlen)
{
    if (err && errlen)
        err[0] = '\0';
    if (!out)
        return sc_scene_errf(err, errlen, SC_ERR_INVALID_ARGUMENT, "NULL output pointer");
    *out = NULL;
    if (!spec || !*spec)
        return sc_scene_errf(err, errlen, SC_ERR_INVALID_ARGUMENT, "empty scene name");
    sc_scene *s;
    sc_status st = sc_scene_create(options, &s);
    if (st != SC_OK)
        return sc_scene_errf(err, errlen, st, "%s", sc_strerror(st));

    int json = strncmp(spec, "proc:", 5) != 0 && strncmp(spec, "cache:", 6) != 0 &&
               has_suffix_ci(spec, ".json");
    if (json)
        st = sc_scene_load_json_file(s, spec, append_spec, err, errlen);
    else
        st = append_spec(s, spec, NULL, NULL, NULL, err, errlen);
    return finish_load(s, st, spec, json, out, err, errlen);
}

sc_status sc_scene_load_json_text(const char *text, size_t len, const char *name,
                                  const char *base_dir, const sc_scene_options *options,
                                  sc_scene **out, char *err, size_t errlen)
{
    if (err && errlen)
        err[0] = '\0';
    if (!out)
        return sc_scene_errf(err, errlen, SC_ERR_INVALID_ARGUMENT, "NULL output pointer");
    *out = NULL;
    if (!text && len > 0)
        return sc_scene_errf(err, errlen, SC_ERR_INVALID_ARGUMENT, "NULL scene text");
    if (!name || !*name)
        name = "<memory>";
    if (!base_dir || !*base_dir)
        base_dir = ".";
    if (len >= SIZE_MAX)
        return sc_scene_errf(err, errlen, SC_ERR_LIMIT, "%s: scene text too large", name);
    /* cJSON wants the terminating NUL inside the buffer it is given. */
    char *buf = malloc(len + 1);
    if (!buf)
        return sc_scene_errf(err, errlen, SC_ERR_OUT_OF_MEMORY, "%s: out of memory", name);
    if (len)
        memcpy(buf, text, len);
    buf[len] = '\0';
    sc_scene *s;
    sc_status st = sc_scene_create(options, &s);
    if (st != SC_OK) {
        free(buf);
        return sc_scene_errf(err, errlen, st, "%s", sc_strerror(st));
    }
    st = sc_scene_load_json_buffer(s, name, base_dir, buf, len, append_spec, err, errlen);
    free(buf);
    return finish_load(s, st, name, 1, out, err, errlen);
}
