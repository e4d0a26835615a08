/* error.c - the one error-reporting path: a status plus a message naming what failed. */
#include "opaline.h"

#include <stdarg.h>
#include <string.h>

op_status op_error_set(op_error *err, op_status status, const char *fmt, ...)
{
    if (err) {
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(err->message, sizeof err->message, fmt, ap);
        va_end(ap);
        err->status = status;
    }
    return status;
}

op_status op_error_prefix(op_error *err, const char *fmt, ...)
{
    if (!err)
        return OP_ERR_INTERNAL;
    char prefix[512], old[sizeof err->message];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(prefix, sizeof prefix, fmt, ap);
    va_end(ap);
    memcpy(old, err->message, sizeof old);
    size_t n = strnlen(prefix, sizeof prefix);
    memcpy(err->message, prefix, n);
    size_t rest = strnlen(old, sizeof old);
    if (rest > sizeof err->message - 1 - n)
        rest = sizeof err->message - 1 - n;
    memcpy(err->message + n, old, rest);
    err->message[n + rest] = '\0';
    return err->status;
}

int op_exit_code(op_status status)
{
    switch (status) {
    case OP_OK:
        return 0;
    case OP_ERR_INPUT:
    case OP_ERR_FORMAT:
        return 2;
    case OP_ERR_CANCELLED:
        return 130;
    default:
        return 1;
    }
}

const char *op_status_name(op_status status)
{
    switch (status) {
    case OP_OK: return "ok";
    case OP_ERR_INPUT: return "invalid input";
    case OP_ERR_FORMAT: return "invalid file";
    case OP_ERR_IO: return "i/o error";
    case OP_ERR_NOMEM: return "out of memory";
    case OP_ERR_NUMERIC: return "numerical failure";
    case OP_ERR_CANCELLED: return "cancelled";
    case OP_ERR_INTERNAL: return "internal error";
    }
    return "unknown error";
}
