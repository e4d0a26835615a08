/* log.c - the one logger: leveled lines on stderr, with text from files made harmless. */
#include "opaline.h"

#include <stdarg.h>
#include <string.h>

/* Written once at start-up, before any thread starts, then only read. */
static op_log_level max_level = OP_LOG_INFO;
static op_log_hook_fn hook;
static void *hook_user;

void op_log_set_hook(op_log_hook_fn fn, void *user)
{
    hook = fn;
    hook_user = user;
}

void op_log_set_level(op_log_level level)
{
    max_level = level;
}

op_log_level op_log_get_level(void)
{
    return max_level;
}

/* The length of the valid UTF-8 sequence at s that encodes a printable (non-C1) code point,
 * or 0. */
static size_t utf8_printable(const unsigned char *s)
{
    unsigned c = s[0];
    if (c >= 0xc2 && c <= 0xdf)
        return (s[1] & 0xc0) == 0x80 && !(c == 0xc2 && s[1] < 0xa0) ? 2 : 0;
    if (c >= 0xe0 && c <= 0xef) {
        unsigned lo = c == 0xe0 ? 0xa0 : 0x80, hi = c == 0xed ? 0x9f : 0xbf;
        return s[1] >= lo && s[1] <= hi && (s[2] & 0xc0) == 0x80 ? 3 : 0;
    }
    if (c >= 0xf0 && c <= 0xf4) {
        unsigned lo = c == 0xf0 ? 0x90 : 0x80, hi = c == 0xf4 ? 0x8f : 0xbf;
        return s[1] >= lo && s[1] <= hi && (s[2] & 0xc0) == 0x80 && (s[3] & 0xc0) == 0x80 ? 4
                                                                                           : 0;
    }
    return 0;
}

size_t op_text_escape(char *dst, size_t cap, const char *src)
{
    if (cap == 0)
        return 0;
    size_t k = 0;
    const unsigned char *s = (const unsigned char *)src;
    while (*s) {
        char esc[8];
        const char *piece = (const char *)s;
        size_t n = 1;
        if (*s >= 0x80)
            n = utf8_printable(s);
        if (*s < 0x20 || *s == 0x7f || n == 0) {
            const char *named = *s == '\t' ? "t" : *s == '\n' ? "n" : *s == '\r' ? "r" : NULL;
            if (named)
                n = (size_t)snprintf(esc, sizeof esc, "\\%s", named);
            else
                n = (size_t)snprintf(esc, sizeof esc, "\\x%02x", *s);
            piece = esc;
            s++;
        } else {
            s += n;
        }
        if (k + n >= cap) /* never a cut escape or character */
            break;
        memcpy(dst + k, piece, n);
        k += n;
    }
    dst[k] = '\0';
    return k;
}

void op_log(op_log_level level, const char *fmt, ...)
{
    static const char *names[] = {"error", "warning", "info", "debug"};
    if (level > max_level)
        return;
    char line[2048], safe[4096];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(line, sizeof line, fmt, ap);
    va_end(ap);
    /* Messages quote names, paths and values read from files. */
    op_text_escape(safe, sizeof safe, line);
    /* One fprintf per line: stdio locks the stream, so lines from threads never interleave. */
    fprintf(stderr, "opaline: %s: %s\n", names[level], safe);
    if (hook)
        hook(hook_user, level, safe);
}
