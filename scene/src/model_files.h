/* The files a model file names, kept inside the model's folder. A glTF's
 * buffer URIs, an OBJ's mtllib and a glTF's image files are all read
 * through here: assimp through the aiFileIO this provides (aiImportFileEx),
 * textures through model_files_open. One rule for all of them: the path,
 * every symlink resolved (realpath), must lie inside the folder of the
 * model file (that folder resolved the same way), and be a regular file,
 * opened without blocking (a FIFO would block until a writer came). A
 * buffer URI "../../x.bin" or a texture symlink to /etc/passwd is refused
 * with a message naming the model file and the path.
 *
 *     model_files files;
 *     cv_result r = model_files_init(&files, "scenes/room.gltf");
 *     const struct aiScene *ai = aiImportFileEx(path, flags, &files.io);
 *     if (files.refused != CV_OK) ... // cv_error(files.refused, "%s", files.message)
 *
 * assimp is told only "cannot open" for a refused file (it carries on where
 * a file is optional, as for a missing mtllib): the first refusal is kept
 * here and the caller fails the import with it. A file that does not exist
 * is not a refusal: assimp reports it as before. */
#ifndef CORVID_SCENE_MODEL_FILES_H
#define CORVID_SCENE_MODEL_FILES_H

#include <assimp/cfileio.h>
#include <limits.h>
#include <stdio.h>

#include "corvid/result.h"

typedef struct model_files {
    struct aiFileIO io;  /* first: assimp hands back &io */
    const char *model;   /* the model file as the caller named it */
    char root[PATH_MAX]; /* its folder, symlinks resolved */
    cv_result refused;   /* the first refusal of a file assimp asked for, CV_OK if none */
    char message[1024];  /* its message */
} model_files;

/* CV_ERROR_NOT_FOUND or CV_ERROR_IO when the model's folder cannot be resolved. */
cv_result model_files_init(model_files *m, const char *model);

/* Opens `file` (a path as the model's folder joined with a URI) for
 * reading. Refused, with `what` first in the message: CV_ERROR_NOT_FOUND for
 * no such file, CV_ERROR_MALFORMED for a path that resolves outside the
 * model's folder, CV_ERROR_IO for one that is not a regular file or cannot
 * be opened. */
cv_result model_files_open(const model_files *m, const char *file, const char *what, FILE **out);

#endif
