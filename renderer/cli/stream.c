/* stream.c - the tile stream's records (stream.h). */
#include "stream.h"

#include <errno.h>
#include <pthread.h>
#include <stdlib.h>
#include <string.h>

struct op_stream {
    pthread_mutex_t lock; /* one record at a time: tiles, progress and log lines interleave */
    FILE *f;
    atomic_int *cancel;
    int error; /* errno of the first failed write; nothing is written after it */
};

op_stream *op_stream_new(FILE *f, atomic_int *cancel)
{
    op_stream *s = calloc(1, sizeof *s);
    if (!s)
        return NULL;
    pthread_mutex_init(&s->lock, NULL);
    s->f = f;
    s->cancel = cancel;
    return s;
}

void op_stream_free(op_stream *s)
{
    if (!s)
        return;
    pthread_mutex_destroy(&s->lock);
    free(s);
}

int op_stream_error(const op_stream *s)
{
    return s->error;
}

static void failed(op_stream *s)
{
    s->error = errno ? errno : EIO;
    if (s->cancel)
        atomic_store(s->cancel, 1);
}

/* Writes n bytes unless a write failed before. The caller holds the lock. */
static void put(op_stream *s, const void *p, size_t n)
{
    if (s->error || n == 0)
        return;
    errno = 0;
    if (fwrite(p, 1, n, s->f) != n)
        failed(s);
}

/* A record's header; the caller then puts exactly n payload bytes and calls record_end. */
static void record_start(op_stream *s, op_stream_record type, uint64_t n)
{
    unsigned char h[16];
    memcpy(h, "OPTS", 4);
    op_put_le32(h + 4, (uint32_t)type);
    op_put_le64(h + 8, n);
    put(s, h, sizeof h);
}

/* Flushes the record, so the reader gets it now (and a write error shows now). */
static void record_end(op_stream *s)
{
    errno = 0;
    if (!s->error && fflush(s->f) != 0)
        failed(s);
}

static void record(op_stream *s, op_stream_record type, const void *payload, size_t n)
{
    pthread_mutex_lock(&s->lock);
    record_start(s, type, n);
    put(s, payload, n);
    record_end(s);
    pthread_mutex_unlock(&s->lock);
}

static void put_f64(unsigned char *p, double v)
{
    uint64_t bits;
    memcpy(&bits, &v, 8);
    op_put_le64(p, bits);
}

void op_stream_begin(op_stream *s, int width, int height, int tile_size)
{
    unsigned char p[16];
    op_put_le32(p, (uint32_t)width);
    op_put_le32(p + 4, (uint32_t)height);
    op_put_le32(p + 8, 4);
    op_put_le32(p + 12, (uint32_t)tile_size);
    record(s, OP_RECORD_BEGIN, p, sizeof p);
}

static int host_le(void)
{
    uint16_t one = 1;
    unsigned char b;
    memcpy(&b, &one, 1);
    return b == 1;
}

void op_stream_tile(void *user, const op_render_tile *t)
{
    op_stream *s = user;
    size_t nf = (size_t)t->w * t->h * 4;
    unsigned char head[16];
    op_put_le32(head, (uint32_t)t->x);
    op_put_le32(head + 4, (uint32_t)t->y);
    op_put_le32(head + 8, (uint32_t)t->w);
    op_put_le32(head + 12, (uint32_t)t->h);
    pthread_mutex_lock(&s->lock);
    record_start(s, OP_RECORD_TILE, sizeof head + 4 * (uint64_t)nf);
    put(s, head, sizeof head);
    if (host_le()) {
        put(s, t->rgba, nf * 4);
    } else {
        unsigned char b[4 * 256];
        for (size_t i = 0; i < nf; i += 256) {
            size_t m = nf - i < 256 ? nf - i : 256;
            for (size_t k = 0; k < m; k++) {
                uint32_t v;
                memcpy(&v, &t->rgba[i + k], 4);
                op_put_le32(b + 4 * k, v);
            }
            put(s, b, 4 * m);
        }
    }
    record_end(s);
    pthread_mutex_unlock(&s->lock);
}

void op_stream_progress(void *user, const char *label, double fraction, double eta)
{
    (void)eta;
    size_t n = strlen(label);
    if (n > 255)
        n = 255;
    unsigned char p[12 + 255];
    put_f64(p, fraction);
    op_put_le32(p + 8, (uint32_t)n);
    memcpy(p + 12, label, n);
    record(user, OP_RECORD_PROGRESS, p, 12 + n);
}

void op_stream_log(void *user, op_log_level level, const char *message)
{
    op_stream *s = user;
    size_t n = strlen(message);
    unsigned char p[4];
    op_put_le32(p, (uint32_t)level);
    pthread_mutex_lock(&s->lock);
    record_start(s, OP_RECORD_LOG, 4 + (uint64_t)n);
    put(s, p, 4);
    put(s, message, n);
    record_end(s);
    pthread_mutex_unlock(&s->lock);
}

void op_stream_stats(op_stream *s, const op_render_stats *rs)
{
    unsigned char p[5 * 8 + 4 * 4 + 2 * 8];
    const long long counts[5] = {rs->sss_points, rs->sss_sources, rs->sss_receivers,
                                 rs->sss_sources_reused, rs->sss_receivers_reused};
    const int small[4] = {rs->sss_shapes_reached, rs->sss_shapes_capped, rs->tiles,
                          rs->tiles_done};
    for (int i = 0; i < 5; i++)
        op_put_le64(p + 8 * i, (uint64_t)counts[i]);
    for (int i = 0; i < 4; i++)
        op_put_le32(p + 40 + 4 * i, (uint32_t)small[i]);
    put_f64(p + 56, rs->sss_seconds);
    put_f64(p + 64, rs->render_seconds);
    record(s, OP_RECORD_STATS, p, sizeof p);
}

void op_stream_end(op_stream *s, int status)
{
    unsigned char p[4];
    op_put_le32(p, (uint32_t)status);
    record(s, OP_RECORD_END, p, sizeof p);
}
