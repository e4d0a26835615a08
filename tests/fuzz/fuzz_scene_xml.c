/* fuzz_scene_xml.c - the scene description parser (includes, refs, defaults, every value kind)
 * on arbitrary bytes. */
#include "fuzz_support.h"

#include "scene_desc.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    op_node *root;
    op_error err;
    if (op_desc_parse(op_fuzz_file(data, size, ".xml"), NULL, 0, &root, &err) == OP_OK)
        op_desc_free(root);
    return 0;
}
