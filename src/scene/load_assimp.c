/* Mesh files through assimp's C API: flattened node transforms, triangles
 * only, one colour per mesh. */
#define _POSIX_C_SOURCE 200809L
#include <errno.h>
#include <pthread.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include <assimp/cimport.h>
#include <assimp/material.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>

#include "load_assimp.h"

/* Deep enough for any real hierarchy, shallow enough that a hostile file
 * cannot exhaust the stack through us. */
#define MAX_NODE_DEPTH 512
#define MAX_LOG_LINES 32
#define MAX_MISSING_MATERIALS 16

/* assimp's logger is a process-wide singleton, so the capture of its
 * messages for one import must not interleave with another import. */
static pthread_mutex_t import_lock = PTHREAD_MUTEX_INITIALIZER;

/* assimp_assert.cpp: makes assimp's aborting asserts throw instead. */
int sc_scene_assimp_assert_hook(void);

typedef struct log_capture {
    char lines[MAX_LOG_LINES][200];
    int nlines;
    size_t dropped;
    char missing[MAX_MISSING_MATERIALS][128];
    int nmissing;
} log_capture;

static void log_callback(const char *msg, char *user)
{
    log_capture *c = (log_capture *)(void *)user;
    if (strncmp(msg, "Warn", 4) != 0 && strncmp(msg, "Error", 5) != 0)
        return;
    const char *text = strstr(msg, ": ");
    text = text ? text + 2 : msg;
    /* The OBJ loader substitutes a material it cannot find; remember the
     * name so that mesh gets our default colour, not assimp's stand-in. */
    static const char key[] = "failed to locate material ";
    const char *m = strstr(text, key);
    if (m && c->nmissing < MAX_MISSING_MATERIALS) {
        m += sizeof key - 1;
        const char *end = strstr(m, ", creating new material");
        size_t n = end ? (size_t)(end - m) : strcspn(m, "\r\n");
        if (n >= sizeof c->missing[0])
            n = sizeof c->missing[0] - 1;
        memcpy(c->missing[c->nmissing], m, n);
        c->missing[c->nmissing][n] = '\0';
        c->nmissing++;
    }
    if (c->nlines < MAX_LOG_LINES) {
        snprintf(c->lines[c->nlines], sizeof c->lines[0], "%s", text);
        c->nlines++;
    } else {
        c->dropped++;
    }
}

typedef struct walk_ctx {
    sc_scene *s;
    const struct aiScene *ai;
    const char *path;
    const float *color_override;
    const log_capture *log;
    float *tmp_pos;
    size_t tmp_pos_cap;
    uint32_t *tmp_idx;
    size_t tmp_idx_cap;
    char *err;
    size_t errlen;
} walk_ctx;

static void mat_from_ai(double m[16], const struct aiMatrix4x4 *a)
{
    const ai_real v[16] = { a->a1, a->a2, a->a3, a->a4, a->b1, a->b2, a->b3, a->b4,
                            a->c1, a->c2, a->c3, a->c4, a->d1, a->d2, a->d3, a->d4 };
    for (int i = 0; i < 16; i++)
        m[i] = v[i];
}

static void mat_mul(double o[16], const double a[16], const double b[16])
{
    double r[16];
    for (int i = 0; i < 4; i++)
        for (int j = 0; j < 4; j++) {
            double acc = 0;
            for (int k = 0; k < 4; k++)
                acc += a[4 * i + k] * b[4 * k + j];
            r[4 * i + j] = acc;
        }
    memcpy(o, r, sizeof r);
}

/* The author's material of mesh, or NULL for none or one of assimp's
 * placeholders (they carry assimp's colours, not the author's). */
static const struct aiMaterial *mesh_material(const walk_ctx *w, const struct aiMesh *mesh)
{
    if (mesh->mMaterialIndex >= w->ai->mNumMaterials || !w->ai->mMaterials)
        return NULL;
    const struct aiMaterial *mat = w->ai->mMaterials[mesh->mMaterialIndex];
    if (!mat)
        return NULL;
    struct aiString name;
    if (aiGetMaterialString(mat, AI_MATKEY_NAME, &name) == aiReturn_SUCCESS) {
        if (strcmp(name.data, AI_DEFAULT_MATERIAL_NAME) == 0)
            return NULL;
        for (int i = 0; i < w->log->nmissing; i++)
            if (strcmp(name.data, w->log->missing[i]) == 0)
                return NULL;
    }
    return mat;
}

static void mesh_color(const walk_ctx *w, const struct aiMesh *mesh, float out[3])
{
    out[0] = out[1] = out[2] = SC_DEFAULT_GREY;
    if (w->color_override) {
        memcpy(out, w->color_override, 3 * sizeof(float));
        return;
    }
    const struct aiMaterial *mat = mesh_material(w, mesh);
    struct aiColor4D c;
    if (mat && (aiGetMaterialColor(mat, AI_MATKEY_COLOR_DIFFUSE, &c) == aiReturn_SUCCESS ||
                aiGetMaterialColor(mat, AI_MATKEY_BASE_COLOR, &c) == aiReturn_SUCCESS)) {
        out[0] = (float)c.r;
        out[1] = (float)c.g;
        out[2] = (float)c.b;
    }
}

/* The emissive colour of the material (OBJ's Ke, glTF's emissiveFactor,
 * ...) as radiance; 0 when absent or out of range. */
static int mesh_emission(const walk_ctx *w, const struct aiMesh *mesh, float out[3])
{
    const struct aiMaterial *mat = mesh_material(w, mesh);
    struct aiColor4D c;
    if (!mat || aiGetMaterialColor(mat, AI_MATKEY_COLOR_EMISSIVE, &c) != aiReturn_SUCCESS)
        return 0;
    out[0] = (float)c.r;
    out[1] = (float)c.g;
    out[2] = (float)c.b;
    for (int i = 0; i < 3; i++)
        if (!(out[i] >= 0 && out[i] <= SC_SCENE_MAX_EMISSION))
            return 0;
    return out[0] > 0 || out[1] > 0 || out[2] > 0;
}

static sc_status add_ai_mesh(walk_ctx *w, const struct aiMesh *mesh, const double m[16])
{
    size_t nv = mesh->mNumVertices;
    if (nv == 0 || !mesh->mVertices || !mesh->mFaces)
        return SC_OK;
    size_t nt = 0, skipped = 0;
    for (unsigned f = 0; f < mesh->mNumFaces; f++) {
        const struct aiFace *face = &mesh->mFaces[f];
        if (face->mNumIndices != 3 || !face->mIndices) {
            skipped++;
            continue;
        }
        for (int k = 0; k < 3; k++)
            if (face->mIndices[k] >= nv)
                return sc_scene_errf(w->err, w->errlen, SC_ERR_PARSE,
                                     "%s: face %u has vertex index %u out of range (%zu vertices)",
                                     w->path, f, face->mIndices[k], nv);
        nt++;
    }
    w->s->skipped_primitives += skipped;
    if (nt == 0)
        return SC_OK;
    /* Caps first, before the temporary copy of an oversize mesh. */
    sc_status st = sc_scene_reserve(w->s, nv, nt, w->err, w->errlen);
    if (st != SC_OK)
        return st;
    if (nv > w->tmp_pos_cap) {
        float *p = realloc(w->tmp_pos, nv * 3 * sizeof(float));
        if (!p)
            return sc_scene_errf(w->err, w->errlen, SC_ERR_OUT_OF_MEMORY, "out of memory");
        w->tmp_pos = p;
        w->tmp_pos_cap = nv;
    }
    if (nt > w->tmp_idx_cap) {
        uint32_t *p = realloc(w->tmp_idx, nt * 3 * sizeof(uint32_t));
        if (!p)
            return sc_scene_errf(w->err, w->errlen, SC_ERR_OUT_OF_MEMORY, "out of memory");
        w->tmp_idx = p;
        w->tmp_idx_cap = nt;
    }
    for (size_t v = 0; v < nv; v++) {
        const struct aiVector3D *p = &mesh->mVertices[v];
        double x = p->x, y = p->y, z = p->z;
        for (int i = 0; i < 3; i++)
            w->tmp_pos[3 * v + i] =
                (float)(m[4 * i] * x + m[4 * i + 1] * y + m[4 * i + 2] * z + m[4 * i + 3]);
    }
    size_t t = 0;
    for (unsigned f = 0; f < mesh->mNumFaces; f++) {
        const struct aiFace *face = &mesh->mFaces[f];
        if (face->mNumIndices != 3 || !face->mIndices)
            continue;
        for (int k = 0; k < 3; k++)
            w->tmp_idx[3 * t + k] = face->mIndices[k];
        t++;
    }
    float color[3], emission[3];
    mesh_color(w, mesh, color);
    size_t id = w->s->num_meshes;
    st = sc_scene_add_mesh(w->s, w->tmp_pos, nv, w->tmp_idx, nt, color, w->err, w->errlen);
    if (st == SC_OK && w->s->num_meshes > id && mesh_emission(w, mesh, emission))
        st = sc_scene_set_mesh_emission(w->s, id, emission);
    return st;
}

static sc_status walk(walk_ctx *w, const struct aiNode *node, const double parent[16], int depth)
{
    if (depth > MAX_NODE_DEPTH)
        return sc_scene_errf(w->err, w->errlen, SC_ERR_PARSE,
                             "%s: node hierarchy deeper than %d levels", w->path, MAX_NODE_DEPTH);
    double m[16], local[16];
    mat_from_ai(local, &node->mTransformation);
    mat_mul(m, parent, local);
    for (unsigned i = 0; i < node->mNumMeshes; i++) {
        unsigned id = node->mMeshes ? node->mMeshes[i] : UINT32_MAX;
        if (id >= w->ai->mNumMeshes || !w->ai->mMeshes[id])
            return sc_scene_errf(w->err, w->errlen, SC_ERR_PARSE,
                                 "%s: node refers to mesh %u of %u", w->path, id, w->ai->mNumMeshes);
        sc_status st = add_ai_mesh(w, w->ai->mMeshes[id], m);
        if (st != SC_OK)
            return st;
    }
    for (unsigned i = 0; i < node->mNumChildren; i++) {
        if (!node->mChildren || !node->mChildren[i])
            continue;
        sc_status st = walk(w, node->mChildren[i], m, depth + 1);
        if (st != SC_OK)
            return st;
    }
    return SC_OK;
}

/* Checks what assimp would report vaguely ("No suitable reader", "file is
 * too small") so the user hears the real reason, and screens out inputs
 * that hang the Debian build of assimp 5.2 outright. */
sc_status sc_scene_check_mesh_file(const char *path, char *err, size_t errlen)
{
    struct stat sb;
    if (stat(path, &sb) != 0)
        return sc_scene_errf(err, errlen, SC_ERR_IO, "%s: %s", path, strerror(errno));
    if (S_ISDIR(sb.st_mode))
        return sc_scene_errf(err, errlen, SC_ERR_IO, "%s: is a directory, not a mesh file", path);
    if (!S_ISREG(sb.st_mode))
        return sc_scene_errf(err, errlen, SC_ERR_IO, "%s: not a regular file", path);
    FILE *f = fopen(path, "rb");
    if (!f)
        return sc_scene_errf(err, errlen, SC_ERR_IO, "%s: %s", path, strerror(errno));
    if (sb.st_size == 0) {
        fclose(f);
        return sc_scene_errf(err, errlen, SC_ERR_PARSE, "%s: empty file", path);
    }
    /* A PLY header cut before "end_header" sends assimp's PLY reader into
     * an endless loop; headers are short, so look for the end marker. */
    enum { HEAD = 1 << 16 };
    char *head = malloc(HEAD);
    if (!head) {
        fclose(f);
        return sc_scene_errf(err, errlen, SC_ERR_OUT_OF_MEMORY, "out of memory");
    }
    size_t n = fread(head, 1, HEAD, f);
    fclose(f);
    int bad_ply = 0, line = 1;
    if (n >= 4 && memcmp(head, "ply", 3) == 0 && (head[3] == '\n' || head[3] == '\r')) {
        /* The same reader also loops forever on a damaged keyword inside
         * the element declarations ("p/operty"). Free-form lines before the
         * first "element" are common (Blender writes one) and harmless. */
        static const char *const keys[] = { "ply", "format", "comment", "obj_info", "element",
                                            "property", "end_header" };
        bad_ply = 1;
        int in_elements = 0;
        size_t i = 0;
        while (i < n) {
            size_t e = i;
            while (e < n && head[e] != '\n')
                e++;
            if (e == n)
                break;   /* header longer than we read, or cut: no end_header */
            size_t w = i;
            while (w < e && head[w] != ' ' && head[w] != '\t' && head[w] != '\r')
                w++;
            int known = 0;
            for (size_t k = 0; k < sizeof keys / sizeof keys[0] && !known; k++)
                known = strlen(keys[k]) == w - i && memcmp(head + i, keys[k], w - i) == 0;
            if (!known && in_elements) {
                bad_ply = 2;
                break;
            }
            in_elements |= w - i == 7 && memcmp(head + i, "element", 7) == 0;
            if (w - i == 10 && memcmp(head + i, "end_header", 10) == 0) {
                bad_ply = 0;
                break;
            }
            i = e + 1;
            line++;
        }
    }
    free(head);
    if (bad_ply == 1)
        return sc_scene_errf(err, errlen, SC_ERR_PARSE,
                             "%s: PLY header without end_header (truncated file?)", path);
    if (bad_ply == 2)
        return sc_scene_errf(err, errlen, SC_ERR_PARSE,
                             "%s: PLY header line %d is not a property or element declaration", path, line);
    return SC_OK;
}

/* The Debian build of assimp keeps its ai_asserts, and Triangulate asserts
 * (aborting the process) when a mesh's mPrimitiveTypes claims polygons that
 * its faces do not have, as truncated PLY files produce. So the file is
 * imported with validation only, checked and repaired here, and only then
 * post-processed. 0 = fine; otherwise err is filled. */
static int sanitize(struct aiScene *ai, const char *path, char *err, size_t errlen)
{
    if (ai->mNumMeshes && !ai->mMeshes) {
        sc_scene_errf(err, errlen, SC_ERR_PARSE, "%s: mesh table missing", path);
        return -1;
    }
    for (unsigned m = 0; m < ai->mNumMeshes; m++) {
        struct aiMesh *mesh = ai->mMeshes[m];
        if (!mesh)
            continue;
        if ((mesh->mNumVertices && !mesh->mVertices) || (mesh->mNumFaces && !mesh->mFaces)) {
            sc_scene_errf(err, errlen, SC_ERR_PARSE, "%s: mesh %u lacks its arrays", path, m);
            return -1;
        }
        unsigned types = 0;
        for (unsigned f = 0; f < mesh->mNumFaces; f++) {
            const struct aiFace *face = &mesh->mFaces[f];
            if (face->mNumIndices == 0 || !face->mIndices) {
                sc_scene_errf(err, errlen, SC_ERR_PARSE, "%s: mesh %u face %u has no indices",
                              path, m, f);
                return -1;
            }
            for (unsigned k = 0; k < face->mNumIndices; k++)
                if (face->mIndices[k] >= mesh->mNumVertices) {
                    sc_scene_errf(err, errlen, SC_ERR_PARSE,
                                  "%s: mesh %u face %u: vertex index %u out of range (%u vertices)",
                                  path, m, f, face->mIndices[k], mesh->mNumVertices);
                    return -1;
                }
            types |= face->mNumIndices == 1   ? aiPrimitiveType_POINT
                     : face->mNumIndices == 2 ? aiPrimitiveType_LINE
                     : face->mNumIndices == 3 ? aiPrimitiveType_TRIANGLE
                                              : aiPrimitiveType_POLYGON;
        }
        mesh->mPrimitiveTypes = types;
    }
    return 0;
}

sc_status sc_scene_import_assimp(sc_scene *s, const char *path, const double xform[16],
                                 const float *color, int take_lock, char *err, size_t errlen)
{
    sc_status st = SC_OK;
    if (!sc_scene_assimp_assert_hook())
        return SC_ERR_UNSUPPORTED;

    log_capture *log = calloc(1, sizeof *log);
    if (!log)
        return sc_scene_errf(err, errlen, SC_ERR_OUT_OF_MEMORY, "out of memory");
    if (take_lock)
        pthread_mutex_lock(&import_lock);
    struct aiLogStream stream = { log_callback, (char *)(void *)log };
    aiAttachLogStream(&stream);
    const struct aiScene *ai = aiImportFile(path, aiProcess_ValidateDataStructure);
    char aierr[256] = "";
    if (!ai) {
        snprintf(aierr, sizeof aierr, "%s", aiGetErrorString());
    } else if (sanitize((struct aiScene *)(uintptr_t)ai, path, aierr, sizeof aierr) != 0) {
        aiReleaseImport(ai);
        ai = NULL;
        st = SC_ERR_PARSE;
    } else {
        /* Degenerate triangles are kept on purpose: no FindDegenerates.
         * On failure assimp releases the scene itself. */
        ai = aiApplyPostProcessing(ai, aiProcess_Triangulate | aiProcess_JoinIdenticalVertices |
                                           aiProcess_SortByPType);
        if (!ai)
            snprintf(aierr, sizeof aierr, "%s", aiGetErrorString());
    }
    aiDetachLogStream(&stream);
    if (take_lock)
        pthread_mutex_unlock(&import_lock);

    if (!ai) {
        if (st == SC_ERR_PARSE)   /* aierr is our own complete message */
            st = sc_scene_errf(err, errlen, SC_ERR_PARSE, "%s", aierr);
        else
            st = sc_scene_errf(err, errlen, SC_ERR_PARSE, "%s: %s", path,
                               aierr[0] ? aierr : "assimp could not read the file");
        free(log);
        return st;
    }
    for (int i = 0; i < log->nlines; i++)
        sc_scene_warnf(s, "%s: %s", path, log->lines[i]);
    if (log->dropped)
        sc_scene_warnf(s, "%s: %zu more loader messages", path, log->dropped);

    walk_ctx w = { .s = s, .ai = ai, .path = path, .color_override = color, .log = log,
                   .err = err, .errlen = errlen };
    static const double identity[16] = { 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1 };
    size_t before = s->num_triangles, skipped_before = s->skipped_primitives;
    if (!ai->mRootNode)
        st = sc_scene_errf(err, errlen, SC_ERR_PARSE, "%s: no scene graph", path);
    else
        st = walk(&w, ai->mRootNode, xform ? xform : identity, 0);
    if (st == SC_OK && s->skipped_primitives > skipped_before)
        sc_scene_warnf(s, "%s: ignored %zu point and line primitives", path,
                       s->skipped_primitives - skipped_before);
    if (st == SC_OK && s->num_triangles == before)
        sc_scene_warnf(s, "%s: contains no triangles", path);
    free(w.tmp_pos);
    free(w.tmp_idx);
    free(log);
    aiReleaseImport(ai);
    return st;
}
