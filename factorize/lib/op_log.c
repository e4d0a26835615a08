/* op_log.c - the one logger: leveled lines on stderr. */
#include "opaline.h"

#include <stdarg.h>

/* Written once at start-up, before any thread starts, then only read. */
static op_log_level max_level = OP_LOG_INFO;

void op_log_set_level(op_log_level level)
{
    max_level = level;
}

op_log_level op_log_get_level(void)
{
    return max_level;
}

void op_log(op_log_level level, const char *fmt, ...)
{
    static const char *names[] = {"error", "warning", "info", "debug"};
    if (level > max_level)
        return;
    char line[2048];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(line, sizeof line, fmt, ap);
    va_end(ap);
    /* One fprintf per line: stdio locks the stream, so lines from threads never interleave. */
    fprintf(stderr, "opaline: %s: %s\n", names[level], line);
}
