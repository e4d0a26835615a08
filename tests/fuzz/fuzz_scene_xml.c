/* fuzz_scene_xml.c - the scene description parser (includes, refs, defaults, every value kind)
 * on arbitrary bytes. The input is up to four files, separated by the line "--8<--": a.xml
 * (the scene), b.xml, c.xml and d.xml beside it, so that <include> finds files (nested,
 * repeated, cyclic) and <default>s meet across them. The limits are lowered so that a fan-out
 * or a $parameter bomb is refused within the fuzzer's time per input. */
#include "fuzz_support.h"

#include "scene/scene_desc.h"

#include <stdlib.h>
#include <string.h>

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static const char *names[4] = {"a.xml", "b.xml", "c.xml", "d.xml"};
    static const char cut[] = "\n--8<--\n";
    const char *path = NULL;
    size_t at = 0;
    for (int i = 0; i < 4; i++) {
        size_t end = size;
        if (i < 3)
            for (size_t k = at; k + sizeof cut - 1 <= size; k++)
                if (memcmp(data + k, cut, sizeof cut - 1) == 0) {
                    end = k;
                    break;
                }
        const char *p = op_fuzz_folder_file(names[i], data + at, end - at);
        if (i == 0)
            path = strdup(p);
        at = end < size ? end + sizeof cut - 1 : size;
    }
    op_fuzz_require(path != NULL, "out of memory");
    op_scene_limits lim;
    op_scene_limits_init(&lim);
    lim.include_count = 1000;
    lim.include_bytes = 4 << 20;
    lim.attribute_bytes = 4 << 20;
    op_node *root;
    op_error err;
    if (op_desc_parse(path, NULL, 0, &lim, &root, &err) == OP_OK)
        op_desc_free(root);
    free((void *)path);
    return 0;
}
