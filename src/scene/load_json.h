/* Private to src/scene: scene files ("*.json", format in scenes/README.md). */
#ifndef SPHERECULL_SCENE_LOAD_JSON_H
#define SPHERECULL_SCENE_LOAD_JSON_H

#include "scene_container.h"

/* Reads the file at path and loads it as sc_scene_load_json_buffer does,
 * with relative mesh paths resolved against the file's directory. */
sc_status sc_scene_load_json_file(sc_scene *s, const char *path, sc_scene_append_fn append_mesh,
                                  char *err, size_t errlen);

/* Loads scene text already in memory (NUL at text[len]) into s; each mesh
 * entry goes through append_mesh with base_dir. name labels messages. */
sc_status sc_scene_load_json_buffer(sc_scene *s, const char *name, const char *base_dir,
                                    const char *text, size_t len, sc_scene_append_fn append_mesh,
                                    char *err, size_t errlen);

#endif
