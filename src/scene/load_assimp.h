/* Private to src/scene: mesh files through assimp, in this process or in a
 * child process (scene_load.c chooses, from the scene's import policy). */
#ifndef SPHERECULL_SCENE_LOAD_ASSIMP_H
#define SPHERECULL_SCENE_LOAD_ASSIMP_H

#include "scene_container.h"

/* Cheap checks before any import: missing, directory, empty, PLY headers
 * that hang assimp. */
sc_status sc_scene_check_mesh_file(const char *path, char *err, size_t errlen);

/* The import in this process (load_assimp.c). take_lock: serialise against
 * other threads; a forked child, single-threaded, must not wait on a lock
 * some parent thread held at fork time. */
sc_status sc_scene_import_assimp(sc_scene *s, const char *path, const double xform[16],
                                 const float *color, int take_lock, char *err, size_t errlen);

/* The same import in a child process with a time limit and a memory cap
 * (load_assimp_child.c): a crash or a hang there is one error line here. */
sc_status sc_scene_import_assimp_in_child(sc_scene *s, const char *path, const double xform[16],
                                          const float *color, char *err, size_t errlen);

#endif
