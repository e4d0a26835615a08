/* output.c - crash-safe output files, and the removal of their temporary files when the
 * process is interrupted.
 *
 * An output is written to a temporary file "<dest>.tmp-opaline-<pid>-XXXXXX" beside the file it
 * replaces (symbolic links followed) and renamed over it by commit, keeping the old file's mode
 * (and, for root, its owner). A destination that exists and is a character device or a FIFO is
 * never replaced: the temporary file goes to $TMPDIR and commit copies it through.
 *
 * Invariant: an op_output is on the live list from just before its temporary file is created
 * until just after that file is renamed or removed, and the list's lock is held across each of
 * those steps. The interrupt thread takes the lock and never gives it back (it exits), so it
 * removes exactly the temporary files that exist and no new one appears after. */
#define _GNU_SOURCE
#include "opaline.h"

#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <pthread.h>
#include <semaphore.h>
#include <signal.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#define TEMP_TAG ".tmp-opaline-"
#define MAX_SYMLINKS 40

struct op_output {
    FILE *f;
    char *path;     /* as the caller named it */
    char *dest;     /* the file commit renames over (path, links followed); NULL: write through */
    char *tmp_path; /* the temporary file */
    int failed_errno;
    op_output *prev, *next; /* the live list */
};

static pthread_mutex_t live_lock = PTHREAD_MUTEX_INITIALIZER;
static op_output *live_head;

/* Both with live_lock held. */
static void live_add(op_output *o)
{
    o->prev = NULL;
    o->next = live_head;
    if (live_head)
        live_head->prev = o;
    live_head = o;
}

static void live_remove(op_output *o)
{
    if (o->prev)
        o->prev->next = o->next;
    else if (live_head == o)
        live_head = o->next;
    if (o->next)
        o->next->prev = o->prev;
    o->prev = o->next = NULL;
}

static void output_free(op_output *o)
{
    free(o->tmp_path);
    free(o->dest);
    free(o->path);
    free(o);
}

/* name resolved against the folder of file (name itself when absolute); malloc'ed. */
static char *beside(const char *file, const char *name)
{
    const char *slash = strrchr(file, '/');
    size_t dn = name[0] == '/' || !slash ? 0 : (size_t)(slash - file) + 1;
    char *p = malloc(dn + strlen(name) + 1);
    if (p) {
        memcpy(p, file, dn);
        strcpy(p + dn, name);
    }
    return p;
}

/* Follows the symbolic links at path to the file that a write should replace or create, and
 * fills *st with its lstat (st_mode 0 when it does not exist). Returns a malloc'ed path, or
 * NULL with errno set. */
static char *resolve_destination(const char *path, struct stat *st)
{
    char *cur = strdup(path);
    for (int links = 0; cur; links++) {
        if (lstat(cur, st) != 0) {
            if (errno != ENOENT)
                break;
            memset(st, 0, sizeof *st);
            return cur;
        }
        if (!S_ISLNK(st->st_mode))
            return cur;
        char target[PATH_MAX];
        ssize_t n = links < MAX_SYMLINKS ? readlink(cur, target, sizeof target - 1) : -1;
        if (links >= MAX_SYMLINKS)
            errno = ELOOP;
        if (n < 0)
            break;
        target[n] = '\0';
        char *next = beside(cur, target);
        free(cur);
        cur = next;
    }
    int e = cur ? errno : ENOMEM;
    free(cur);
    errno = e;
    return NULL;
}

/* The pid in a temporary file name "<base>.tmp-opaline-<pid>-XXXXXX" (prefix already
 * matched: s points after it), or -1 when the rest of the name does not have that form. */
static long temp_owner(const char *s)
{
    char *end;
    if (*s < '0' || *s > '9')
        return -1;
    errno = 0;
    long pid = strtol(s, &end, 10);
    if (errno || pid <= 0 || *end != '-' || strlen(end + 1) != 6)
        return -1;
    for (const char *p = end + 1; *p; p++)
        if (!((*p >= '0' && *p <= '9') || (*p >= 'a' && *p <= 'z') || (*p >= 'A' && *p <= 'Z')))
            return -1;
    return pid;
}

/* Removes the temporary files for temp_prefix (a path ending in TEMP_TAG) that a process no
 * longer running left behind (killed by SIGKILL, a power cut); never one whose process lives. */
static void remove_stale_temps(const char *temp_prefix)
{
    char dir[PATH_MAX];
    snprintf(dir, sizeof dir, "%s", temp_prefix);
    char *slash = strrchr(dir, '/');
    const char *base = slash ? temp_prefix + (slash - dir) + 1 : temp_prefix;
    if (!slash)
        snprintf(dir, sizeof dir, ".");
    else
        slash[slash == dir] = '\0'; /* "/x" keeps the root "/" */
    DIR *d = opendir(dir);
    if (!d)
        return;
    size_t bn = strlen(base);
    struct dirent *e;
    while ((e = readdir(d))) {
        long pid = strncmp(e->d_name, base, bn) ? -1 : temp_owner(e->d_name + bn);
        struct stat st;
        if (pid < 0 || pid == (long)getpid() || kill((pid_t)pid, 0) == 0 || errno != ESRCH ||
            fstatat(dirfd(d), e->d_name, &st, AT_SYMLINK_NOFOLLOW) != 0 || !S_ISREG(st.st_mode))
            continue;
        if (unlinkat(dirfd(d), e->d_name, 0) == 0)
            op_log(OP_LOG_INFO, "removed %s%s%s: a temporary file left by process %ld, which is "
                   "no longer running", dir, strcmp(dir, "/") ? "/" : "", e->d_name, pid);
    }
    closedir(d);
}

/* Creates o->tmp_path = temp_prefix + "<pid>-XXXXXX" (mode 0666 less the umask) and opens it
 * for reading and writing; puts o on the live list. Returns 0 or an errno. */
static int create_temp(op_output *o, const char *temp_prefix)
{
    size_t n = strlen(temp_prefix) + 32;
    if (!(o->tmp_path = malloc(n)))
        return ENOMEM;
    static const char letters[] = "abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789";
    struct timespec ts;
    clock_gettime(CLOCK_REALTIME, &ts);
    uint64_t x = op_hash64((uint64_t)ts.tv_nsec ^ (uint64_t)(uintptr_t)o) | 1;
    int fd = -1, e = EEXIST;
    pthread_mutex_lock(&live_lock);
    for (int tries = 0; fd < 0 && e == EEXIST && tries < 100; tries++) {
        char rnd[7];
        for (int i = 0; i < 6; i++) {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            rnd[i] = letters[x % (sizeof letters - 1)];
        }
        rnd[6] = '\0';
        snprintf(o->tmp_path, n, "%s%ld-%s", temp_prefix, (long)getpid(), rnd);
        fd = open(o->tmp_path, O_RDWR | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
        e = fd < 0 ? errno : 0;
    }
    if (fd >= 0 && !(o->f = fdopen(fd, "w+b"))) {
        e = errno;
        close(fd);
        unlink(o->tmp_path);
    }
    if (!e)
        live_add(o);
    pthread_mutex_unlock(&live_lock);
    return e;
}

/* Gives o's temporary file the owner (when root: only root can give a file away) and the
 * permission bits of the file *st that it replaces. Returns 0 or an errno. */
static int keep_owner_and_mode(op_output *o, const struct stat *st)
{
    int fd = fileno(o->f);
    struct stat mine;
    if (geteuid() == 0 && fstat(fd, &mine) == 0 &&
        (mine.st_uid != st->st_uid || mine.st_gid != st->st_gid) &&
        fchown(fd, st->st_uid, st->st_gid) != 0)
        op_log(OP_LOG_WARN, "%s: cannot keep the owner %ld:%ld: %s", o->path, (long)st->st_uid,
               (long)st->st_gid, strerror(errno));
    return fchmod(fd, st->st_mode & 07777) == 0 ? 0 : errno;
}

op_status op_output_open(const char *path, op_output **out, op_error *err)
{
    *out = NULL;
    op_output *o = calloc(1, sizeof *o);
    if (!o || !(o->path = strdup(path))) {
        free(o);
        return op_error_set(err, OP_ERR_NOMEM, "%s: out of memory", path);
    }
    /* stat follows links as open does (also /proc's: /dev/stdout to a pipe is a FIFO). */
    struct stat st;
    char *temp_prefix = NULL;
    if (stat(path, &st) == 0 && !S_ISREG(st.st_mode)) {
        const char *kind = S_ISDIR(st.st_mode)    ? "a directory"
                           : S_ISBLK(st.st_mode)  ? "a block device"
                           : S_ISSOCK(st.st_mode) ? "a socket"
                           : S_ISCHR(st.st_mode) || S_ISFIFO(st.st_mode) ? NULL
                                                                           : "not a regular file";
        if (kind) {
            output_free(o);
            return op_error_set(err, OP_ERR_IO, "%s: is %s; opaline writes regular files, and "
                                "through to character devices (such as /dev/null) and FIFOs",
                                path, kind);
        }
        /* Written through at commit; until then the data waits in $TMPDIR. */
        const char *tmpdir = getenv("TMPDIR"), *slash = strrchr(path, '/');
        if (asprintf(&temp_prefix, "%s/%s%s", tmpdir && tmpdir[0] ? tmpdir : "/tmp",
                     slash ? slash + 1 : path, TEMP_TAG) < 0)
            temp_prefix = NULL;
    } else if ((o->dest = resolve_destination(path, &st))) {
        if (asprintf(&temp_prefix, "%s%s", o->dest, TEMP_TAG) < 0)
            temp_prefix = NULL;
    }
    int e = temp_prefix ? 0 : errno ? errno : ENOMEM;
    if (!e) {
        remove_stale_temps(temp_prefix);
        e = create_temp(o, temp_prefix);
    }
    free(temp_prefix);
    if (!e && o->dest && S_ISREG(st.st_mode))
        e = keep_owner_and_mode(o, &st);
    if (e) {
        op_status status = op_error_set(err, e == ENOMEM ? OP_ERR_NOMEM : OP_ERR_IO,
                                    "%s: cannot create%s%s: %s", path,
                                    o->dest && strcmp(o->dest, path) ? " the link's target " : "",
                                    o->dest && strcmp(o->dest, path) ? o->dest : "",
                                    strerror(e));
        if (o->f)
            op_output_abort(o);
        else
            output_free(o);
        return status;
    }
    *out = o;
    return OP_OK;
}

FILE *op_output_stream(op_output *out)
{
    return out->f;
}

void op_output_write(op_output *out, const void *data, size_t n)
{
    if (n && !out->failed_errno && fwrite(data, 1, n, out->f) != n)
        out->failed_errno = errno ? errno : EIO;
}

op_status op_output_pending(op_output *out, const char **tmp_path, op_error *err)
{
    *tmp_path = NULL;
    if (!out->failed_errno && (fflush(out->f) != 0 || ferror(out->f)))
        out->failed_errno = errno ? errno : EIO;
    if (out->failed_errno)
        return op_error_set(err, OP_ERR_IO, "%s: cannot write: %s", out->path,
                            strerror(out->failed_errno));
    *tmp_path = out->tmp_path;
    return OP_OK;
}

/* Copies the temporary file's contents to out->path (a device or FIFO); returns 0 or errno. */
static int copy_through(op_output *out)
{
    int in = fileno(out->f);
    if (lseek(in, 0, SEEK_SET) != 0)
        return errno;
    int fd = open(out->path, O_WRONLY | O_TRUNC | O_NOCTTY | O_CLOEXEC);
    if (fd < 0)
        return errno;
    enum { CHUNK = 1 << 18 };
    char *buf = malloc(CHUNK);
    int e = buf ? 0 : ENOMEM;
    for (ssize_t n; !e && (n = read(in, buf, CHUNK)) != 0;) {
        if (n < 0) {
            e = errno == EINTR ? 0 : errno;
            continue;
        }
        for (ssize_t done = 0, w; !e && done < n; done += w > 0 ? w : 0)
            if ((w = write(fd, buf + done, (size_t)(n - done))) < 0 && errno != EINTR)
                e = errno;
            else if (w == 0)
                e = EIO;
    }
    free(buf);
    if (close(fd) != 0 && !e && errno != EINTR)
        e = errno;
    return e;
}

op_status op_output_commit(op_output *out, op_error *err)
{
    int e = out->failed_errno;
    if (!e && (fflush(out->f) != 0 || ferror(out->f)))
        e = errno ? errno : EIO;
    if (!e && out->dest && fsync(fileno(out->f)) != 0)
        e = errno;
    if (!e && !out->dest)
        e = copy_through(out);
    if (fclose(out->f) != 0 && !e)
        e = errno ? errno : EIO;
    pthread_mutex_lock(&live_lock);
    if (!e && out->dest && rename(out->tmp_path, out->dest) != 0)
        e = errno;
    if (e || !out->dest)
        unlink(out->tmp_path);
    live_remove(out);
    pthread_mutex_unlock(&live_lock);
    op_status st = OP_OK;
    if (e)
        st = op_error_set(err, OP_ERR_IO, "%s: cannot write: %s", out->path, strerror(e));
    output_free(out);
    return st;
}

void op_output_abort(op_output *out)
{
    if (!out)
        return;
    fclose(out->f);
    pthread_mutex_lock(&live_lock);
    unlink(out->tmp_path);
    live_remove(out);
    pthread_mutex_unlock(&live_lock);
    output_free(out);
}

/* ------------------------------------------------------------ interruption */

static sem_t interrupt_sem;
static volatile sig_atomic_t interrupt_signal;
static op_interrupt_fn interrupt_fn;
static void *interrupt_user;

/* Async-signal-safe: only records the signal and wakes the interrupt thread. */
static void on_interrupt_signal(int signo)
{
    int saved = errno;
    interrupt_signal = signo;
    sem_post(&interrupt_sem);
    errno = saved;
}

static const char *signal_name(int signo)
{
    return signo == SIGINT ? "SIGINT" : signo == SIGTERM ? "SIGTERM" : "SIGHUP";
}

/* Waits for the signals; the first goes to interrupt_fn when there is one, any other removes
 * the live temporary files and exits. A plain thread, so it may lock and log. */
static void *interrupt_thread(void *unused)
{
    (void)unused;
    for (int calls = 0;; calls++) {
        while (sem_wait(&interrupt_sem) != 0)
            ;
        int signo = interrupt_signal;
        if (interrupt_fn && calls == 0) {
            interrupt_fn(interrupt_user, signo);
            continue;
        }
        pthread_mutex_lock(&live_lock); /* kept: no temporary file is made or renamed after */
        int removed = 0;
        for (op_output *o = live_head; o; o = o->next)
            removed += unlink(o->tmp_path) == 0;
        op_log(OP_LOG_ERROR, "interrupted by %s; %d temporary file%s removed", signal_name(signo),
               removed, removed == 1 ? "" : "s");
        _exit(op_exit_code(OP_ERR_CANCELLED));
    }
    return NULL;
}

op_status op_interrupt_install(op_interrupt_fn fn, void *user, op_error *err)
{
    static int installed;
    if (installed++)
        return op_error_set(err, OP_ERR_INTERNAL, "op_interrupt_install called twice");
    interrupt_fn = fn;
    interrupt_user = user;
    if (sem_init(&interrupt_sem, 0, 0) != 0)
        return op_error_set(err, OP_ERR_INTERNAL, "sem_init: %s", strerror(errno));
    /* The thread blocks every signal, so they are handled by the others. */
    sigset_t all, old;
    sigfillset(&all);
    pthread_sigmask(SIG_SETMASK, &all, &old);
    pthread_t t;
    int e = pthread_create(&t, NULL, interrupt_thread, NULL);
    pthread_sigmask(SIG_SETMASK, &old, NULL);
    if (e)
        return op_error_set(err, OP_ERR_INTERNAL, "cannot start the interrupt thread: %s",
                            strerror(e));
    pthread_detach(t);
    struct sigaction sa;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_interrupt_signal;
    sa.sa_flags = SA_RESTART;
    sigemptyset(&sa.sa_mask);
    static const int signals[] = {SIGINT, SIGTERM, SIGHUP};
    for (size_t i = 0; i < sizeof signals / sizeof signals[0]; i++) {
        struct sigaction was;
        /* A signal ignored at start stays ignored (nohup, background jobs of a shell). */
        if (sigaction(signals[i], NULL, &was) == 0 && was.sa_handler != SIG_IGN)
            sigaction(signals[i], &sa, NULL);
    }
    signal(SIGPIPE, SIG_IGN);
    return OP_OK;
}
