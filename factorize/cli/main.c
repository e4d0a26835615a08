/* opaline-factor: makes datasets and turns them into factored materials. */
#include "commands.h"
#include "opaline.h"

#include <errno.h>
#include <stdio.h>
#include <string.h>

static const struct {
    const char *name;
    int (*run)(int argc, char **argv);
    const char *summary;
} commands[] = {
    {"dataset", op_cmd_dataset, "make a synthetic heterogeneous subsurface dataset"},
    {"import", op_cmd_import, "convert a NumPy .npy dataset (3, H, W, K, K) to opaline's format"},
    {"factor", op_cmd_factor, "factor a dataset into a material (svd, tucker, kcta, nmf, raw)"},
    {"info", op_cmd_info, "describe a material or dataset file"},
};

static void usage(FILE *f)
{
    fprintf(f, "usage: opaline-factor COMMAND [OPTIONS]\n\ncommands:\n");
    for (size_t i = 0; i < sizeof commands / sizeof commands[0]; i++)
        fprintf(f, "  %-8s %s\n", commands[i].name, commands[i].summary);
    fprintf(f, "\n'opaline-factor COMMAND --help' describes a command's options.\n");
}

/* A command's exit code, made 1 when it succeeded but what it printed on stdout could not all
 * be written. */
static int check_stdout(int code)
{
    if (code || (fflush(stdout) == 0 && !ferror(stdout)))
        return code;
    op_log(OP_LOG_ERROR, "stdout: cannot write: %s", strerror(errno ? errno : EIO));
    return 1;
}

int main(int argc, char **argv)
{
    op_file_guard_faults(); /* an input file truncated while mapped: a message, exit 2 */
    op_file_protect_inputs(); /* no output replaces a file this run reads */
    /* SIGINT, SIGTERM, SIGHUP: remove the temporary files, exit 130; SIGPIPE: an EPIPE error. */
    op_error err = {0};
    if (op_interrupt_install(NULL, NULL, &err) != OP_OK) {
        op_log(OP_LOG_ERROR, "%s", err.message);
        return op_exit_code(err.status);
    }
    if (argc < 2) {
        op_log(OP_LOG_ERROR, "no command given");
        usage(stderr);
        return 2;
    }
    if (!strcmp(argv[1], "--help") || !strcmp(argv[1], "-h")) {
        usage(stdout);
        return check_stdout(0);
    }
    if (!strcmp(argv[1], "--version")) {
        printf("opaline-factor %s\n", op_version());
        return check_stdout(0);
    }
    for (size_t i = 0; i < sizeof commands / sizeof commands[0]; i++)
        if (!strcmp(argv[1], commands[i].name))
            return check_stdout(commands[i].run(argc - 1, argv + 1));
    op_log(OP_LOG_ERROR, "unknown command '%s'", argv[1]);
    usage(stderr);
    return 2;
}
