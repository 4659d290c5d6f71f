/* See gltf_check.h. */
#include "gltf_check.h"

#include "gltf_materials.h"

#include <cjson/cJSON.h>
#include <errno.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>

#define GLB_MAGIC 0x46546C67u      /* "glTF" */
#define GLB_CHUNK_JSON 0x4E4F534Au /* "JSON" */
#define GLB_HEADER 12u
#define GLB_CHUNK_HEADER 8u

static uint32_t le32(const unsigned char *p) {
    return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}

static bool has_magic(const char *path) {
    unsigned char m[4];
    FILE *f = fopen(path, "rb");
    bool glb = f && fread(m, 1, 4, f) == 4 && le32(m) == GLB_MAGIC;
    if (f)
        fclose(f);
    return glb;
}

bool gltf_is_gltf(const char *path) {
    const char *dot = strrchr(path, '.');
    if (dot && (strcasecmp(dot, ".gltf") == 0 || strcasecmp(dot, ".glb") == 0))
        return true;
    return has_magic(path);
}

/* Reads `size` bytes at `offset`; false on a short read. */
static bool read_at(FILE *f, long offset, void *data, size_t size) {
    return fseek(f, offset, SEEK_SET) == 0 && fread(data, 1, size, f) == size;
}

/* The JSON chunk of a GLB (malloc'd, *size bytes), after checking the
 * header's length against the file and each chunk's length against the rest. */
static cv_result glb_json(const char *path, FILE *f, uint64_t file_size, char **json, size_t *size) {
    unsigned char h[GLB_HEADER + GLB_CHUNK_HEADER];
    if (file_size < GLB_HEADER)
        return cv_error(CV_ERROR_MALFORMED, "%s: truncated GLB: %llu bytes, shorter than its 12-byte header", path,
                        (unsigned long long)file_size);
    if (!read_at(f, 0, h, GLB_HEADER))
        return cv_error(CV_ERROR_IO, "%s: cannot read the GLB header", path);
    uint32_t version = le32(h + 4), length = le32(h + 8);
    if (length > file_size)
        return cv_error(CV_ERROR_MALFORMED, "%s: truncated GLB: its header says %u bytes, the file has %llu", path,
                        length, (unsigned long long)file_size);
    if (length < file_size)
        return cv_error(CV_ERROR_MALFORMED, "%s: corrupt GLB: its header says %u bytes, the file has %llu", path,
                        length, (unsigned long long)file_size);
    if (version != 2)
        return cv_error(CV_ERROR_MALFORMED, "%s: GLB version %u (only glTF 2.0 binaries are read)", path, version);
    uint64_t json_length = 0;
    for (uint64_t at = GLB_HEADER, index = 0; at < length; index++) {
        if (length - at < GLB_CHUNK_HEADER || !read_at(f, (long)at, h, GLB_CHUNK_HEADER))
            return cv_error(CV_ERROR_MALFORMED, "%s: truncated GLB: chunk %llu's header is cut off at byte %llu",
                            path, (unsigned long long)index, (unsigned long long)at);
        uint32_t chunk = le32(h), type = le32(h + 4);
        uint64_t rest = length - at - GLB_CHUNK_HEADER;
        if (chunk > rest)
            return cv_error(CV_ERROR_MALFORMED,
                            "%s: truncated or corrupt GLB: chunk %llu claims %u bytes, only "
                            "%llu follow",
                            path, (unsigned long long)index, chunk, (unsigned long long)rest);
        if (index == 0 && type != GLB_CHUNK_JSON)
            return cv_error(CV_ERROR_MALFORMED, "%s: corrupt GLB: the first chunk is not JSON", path);
        if (index == 0)
            json_length = chunk;
        at += GLB_CHUNK_HEADER + (uint64_t)chunk;
    }
    if (file_size < GLB_HEADER + GLB_CHUNK_HEADER)
        return cv_error(CV_ERROR_MALFORMED, "%s: truncated GLB: no JSON chunk", path);
    char *text = malloc(json_length + 1);
    if (!text)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "%s: no memory for a %llu-byte JSON chunk", path,
                        (unsigned long long)json_length);
    if (!read_at(f, GLB_HEADER + GLB_CHUNK_HEADER, text, json_length)) {
        free(text);
        return cv_error(CV_ERROR_IO, "%s: cannot read the JSON chunk", path);
    }
    *json = text;
    *size = json_length;
    return CV_OK;
}

static cv_result whole_file(const char *path, FILE *f, uint64_t file_size, char **json, size_t *size) {
    char *text = malloc(file_size + 1);
    if (!text)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "%s: no memory for %llu bytes of JSON", path,
                        (unsigned long long)file_size);
    if (!read_at(f, 0, text, file_size)) {
        free(text);
        return cv_error(CV_ERROR_IO, "%s: cannot read it", path);
    }
    *json = text;
    *size = file_size;
    return CV_OK;
}

typedef struct graph {
    const char *path;
    const cJSON *nodes;
    const cJSON **items; /* nodes[i], so that a lookup is not a walk of cJSON's list */
    int count;
    uint8_t *state;     /* 0 unseen, 1 on the current path, 2 expanded */
    uint64_t *expanded; /* instances of the subtree of each node, saturated past the limit */
} graph;

static uint64_t add_saturated(uint64_t a, uint64_t b) {
    uint64_t s = a + b;
    return s > IMPORT_MAX_NODE_INSTANCES ? IMPORT_MAX_NODE_INSTANCES + 1 : s;
}

/* Counts the instances of node n's subtree. */
static cv_result expand(graph *g, int n, int depth) {
    if (g->state[n] == 2)
        return CV_OK;
    if (depth > IMPORT_MAX_NODE_DEPTH)
        return cv_error(CV_ERROR_LIMIT_EXCEEDED, "%s: node tree deeper than %d levels (at node %d)", g->path,
                        IMPORT_MAX_NODE_DEPTH, n);
    if (g->state[n] == 1)
        return cv_error(CV_ERROR_MALFORMED, "%s: the node graph has a cycle through node %d", g->path, n);
    g->state[n] = 1;
    uint64_t total = 1;
    const cJSON *children = cJSON_GetObjectItemCaseSensitive(g->items[n], "children");
    const cJSON *child;
    cJSON_ArrayForEach(child, children) {
        double v = cJSON_IsNumber(child) ? child->valuedouble : -1.0;
        if (!(v >= 0.0 && v < g->count && v == (int)v))
            return cv_error(CV_ERROR_MALFORMED, "%s: node %d has a child that is not a node index in 0..%d", g->path,
                            n, g->count - 1);
        cv_result r = expand(g, (int)v, depth + 1);
        if (r != CV_OK)
            return r;
        total = add_saturated(total, g->expanded[(int)v]);
    }
    g->expanded[n] = total;
    g->state[n] = 2;
    return CV_OK;
}

/* glTF 2.0 node hierarchies are strict trees: "no node may be a direct
 * descendant of more than one node". A node listed as a child twice, by one
 * parent or two, would be copied once per path: 17 nodes that each list the
 * next twice make 2^17 coincident copies of a mesh, and every ray then meets
 * all of them. Refused before anything is expanded, naming both parents. */
static cv_result check_single_parents(const char *path, const cJSON *nodes, int count, int *parent) {
    for (int n = 0; n < count; n++)
        parent[n] = -1;
    int n = 0;
    const cJSON *node, *child;
    cJSON_ArrayForEach(node, nodes) {
        cJSON_ArrayForEach(child, cJSON_GetObjectItemCaseSensitive(node, "children")) {
            double v = cJSON_IsNumber(child) ? child->valuedouble : -1.0;
            if (!(v >= 0.0 && v < count && v == (int)v))
                return cv_error(CV_ERROR_MALFORMED, "%s: node %d has a child that is not a node index in 0..%d", path,
                                n, count - 1);
            int c = (int)v;
            if (parent[c] >= 0)
                return cv_error(CV_ERROR_MALFORMED,
                                "%s: node %d is a child of node %d and again of node %d; glTF 2.0 node hierarchies "
                                "are trees (a node has at most one parent)",
                                path, c, parent[c], n);
            parent[c] = n;
        }
        n++;
    }
    return CV_OK;
}

/* Roots are the nodes the scenes list, or without scenes every node that is
 * no node's child. */
static cv_result check_nodes(const char *path, const cJSON *root) {
    const cJSON *nodes = cJSON_GetObjectItemCaseSensitive(root, "nodes");
    if (!cJSON_IsArray(nodes))
        return CV_OK;
    graph g = { .path = path, .nodes = nodes, .count = cJSON_GetArraySize(nodes) };
    g.state = calloc((size_t)g.count + 1, 1);
    g.expanded = calloc((size_t)g.count + 1, sizeof *g.expanded);
    uint8_t *is_child = calloc((size_t)g.count + 1, 1);
    int *parent = calloc((size_t)g.count + 1, sizeof *parent);
    g.items = calloc((size_t)g.count + 1, sizeof *g.items);
    cv_result r = CV_OK;
    if (!g.state || !g.expanded || !is_child || !parent || !g.items)
        r = cv_error(CV_ERROR_OUT_OF_MEMORY, "%s: no memory for %d nodes", path, g.count);
    int at = 0;
    const cJSON *item;
    cJSON_ArrayForEach(item, nodes) {
        if (g.items)
            g.items[at] = item;
        at++;
    }
    if (r == CV_OK)
        r = check_single_parents(path, nodes, g.count, parent);
    for (int n = 0; r == CV_OK && n < g.count; n++)
        r = expand(&g, n, 0);
    uint64_t total = 0;
    const cJSON *scenes = cJSON_GetObjectItemCaseSensitive(root, "scenes"), *scene, *node;
    if (r == CV_OK && cJSON_GetArraySize(scenes) > 0) {
        cJSON_ArrayForEach(scene, scenes) {
            cJSON_ArrayForEach(node, cJSON_GetObjectItemCaseSensitive(scene, "nodes")) {
                double v = cJSON_IsNumber(node) ? node->valuedouble : -1.0;
                if (!(v >= 0.0 && v < g.count && v == (int)v)) {
                    r = cv_error(CV_ERROR_MALFORMED, "%s: a scene lists a node that is not an index in 0..%d", path,
                                 g.count - 1);
                    break;
                }
                total = add_saturated(total, g.expanded[(int)v]);
            }
        }
    } else if (r == CV_OK) {
        for (int n = 0; n < g.count; n++) {
            cJSON_ArrayForEach(node, cJSON_GetObjectItemCaseSensitive(g.items[n], "children"))
                is_child[(int)node->valuedouble] = 1;
        }
        for (int n = 0; n < g.count; n++)
            total = is_child[n] ? total : add_saturated(total, g.expanded[n]);
    }
    if (r == CV_OK && total > IMPORT_MAX_NODE_INSTANCES)
        r = cv_error(CV_ERROR_LIMIT_EXCEEDED,
                     "%s: the node graph expands to more than %u node instances (a node "
                     "referenced from several parents is copied for each); the limit is %u",
                     path, IMPORT_MAX_NODE_INSTANCES, IMPORT_MAX_NODE_INSTANCES);
    free(g.state);
    free(g.expanded);
    free(is_child);
    free(parent);
    free(g.items);
    return r;
}

/* Whether the text stops inside a string or with brackets still open: it
 * was cut short (cJSON reports an unterminated string at its start). */
static bool ends_open(const char *json, size_t size) {
    bool in_string = false, escaped = false;
    long depth = 0;
    for (size_t i = 0; i < size; i++) {
        char c = json[i];
        if (in_string) {
            in_string = escaped || c != '"';
            escaped = !escaped && c == '\\';
        } else if (c == '"') {
            in_string = true;
        } else {
            depth += (c == '{' || c == '[') - (c == '}' || c == ']');
        }
    }
    return in_string || depth > 0;
}

/* A glTF's JSON is an object: text that does not start as one is not glTF
 * at all, one that does and stops open was cut short. */
static cv_result parse_failure(const char *path, const char *json, size_t size, const char *at) {
    size_t first = strspn(json, " \t\r\n");
    if (first == size || json[first] != '{')
        return cv_error(CV_ERROR_MALFORMED, "%s: invalid glTF: not a JSON object", path);
    if (ends_open(json, size))
        return cv_error(CV_ERROR_MALFORMED,
                        "%s: truncated glTF: its JSON ends early (%zu bytes, brackets or a "
                        "string left open)",
                        path, size);
    size_t offset = at && at >= json && at <= json + size ? (size_t)(at - json) : size;
    return cv_error(CV_ERROR_MALFORMED, "%s: invalid glTF: its JSON does not parse at byte %zu of %zu", path, offset,
                    size);
}

cv_result gltf_check(const char *path) {
    FILE *f = fopen(path, "rb");
    if (!f)
        return cv_error(CV_ERROR_IO, "%s: cannot open: %s", path, strerror(errno));
    struct stat st;
    char *json = NULL;
    size_t size = 0;
    cv_result r = fstat(fileno(f), &st) == 0 ? CV_OK : cv_error(CV_ERROR_IO, "%s: %s", path, strerror(errno));
    if (r == CV_OK)
        r = has_magic(path) ? glb_json(path, f, (uint64_t)st.st_size, &json, &size)
                            : whole_file(path, f, (uint64_t)st.st_size, &json, &size);
    fclose(f);
    if (r != CV_OK)
        return r;
    json[size] = '\0';
    const char *end = NULL;
    cJSON *root = cJSON_ParseWithLengthOpts(json, size, &end, false);
    if (!root)
        r = parse_failure(path, json, size, end);
    else
        r = check_nodes(path, root);
    if (r == CV_OK && root)
        r = gltf_check_materials(path, root);
    cJSON_Delete(root);
    free(json);
    return r;
}
