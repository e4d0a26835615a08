/* info_cmd.c - `opaline-factor info FILE`: prints what a material or dataset file holds. */
#include "commands.h"
#include "opaline.h"
#include "opaline_material.h"

#include <string.h>

int op_cmd_info(int argc, char **argv)
{
    if (argc != 2 || !strcmp(argv[1], "--help")) {
        fprintf(argc == 2 ? stdout : stderr, "usage: opaline-factor info FILE.opm\n");
        return argc == 2 ? 0 : 2;
    }
    op_error err = {0};
    op_material *m;
    op_status st = op_material_open(argv[1], &m, &err);
    if (st != OP_OK) {
        op_log(OP_LOG_ERROR, "%s", err.message);
        return op_exit_code(st);
    }
    const op_material_info *i = op_material_get_info(m);
    /* Names and free text come from the file: escaped, so they cannot drive the terminal. */
    char file[4096], name[4 * sizeof i->name], generator[4 * sizeof i->generator],
        version[4 * sizeof i->tool_version];
    op_text_escape(file, sizeof file, argv[1]);
    op_text_escape(name, sizeof name, i->name);
    op_text_escape(generator, sizeof generator, i->generator);
    op_text_escape(version, sizeof version, i->tool_version);
    printf("file:        %s\n", file);
    printf("name:        %s\n", name);
    printf("method:      %s\n", op_method_name(i->method));
    printf("pixels:      %d x %d, kernel %d x %d, %d channel(s)\n", i->width, i->height,
           i->kernel, i->kernel, i->channels);
    printf("physical:    %g x %g cm (pixel %.4g mm)\n", i->size_x_cm, i->size_y_cm,
           10.0 * i->size_x_cm / i->width);
    if (i->method != OP_METHOD_RAW)
        printf("parameters:  T=%d P=%d C=%d shifted=%d A=%g B=%g\n", i->terms, i->degree,
               i->clusters, i->shifted, i->log_a, i->log_b);
    printf("size:        %llu bytes\n", (unsigned long long)op_material_file_size(m));
    printf("dataset crc: %08x\n", (unsigned)i->dataset_crc);
    printf("generator:   %s\n", generator);
    printf("written by:  opaline %s\n", version);
    op_material_close(m);
    return 0;
}
