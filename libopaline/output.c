/* output.c - crash-safe output files, and the removal of their temporary files when the
 * process is interrupted.
 *
 * An output is written to a temporary file "<dest>.tmp-opaline-<pid>-XXXXXX" beside the file it
 * replaces and renamed over it by commit, keeping the old file's mode, extended attributes (ACLs
 * among them) and, for root, its owner. Symbolic links are followed, except one in a sticky
 * world-writable folder whose owner is neither the caller nor the folder's owner (the kernel's
 * protected_symlinks rule, which a program following links itself must apply itself). A
 * destination that exists and is a character device or a FIFO, or that names a descriptor
 * (/dev/stdout, /dev/fd/N), is never replaced: the temporary file goes to $TMPDIR and commit
 * copies it through; so is a file whose extended attributes cannot be given to a new file.
 *
 * Invariants: an op_output is on the live list from just before its temporary file has a name
 * until just after that name is renamed or removed, and the list's lock is held across each of
 * those steps. The interrupt thread takes the lock and never gives it back (it exits), so it
 * removes exactly the temporary files that exist and no new one appears after. The writer holds
 * an flock on its temporary file from before the file has a name until after it is renamed or
 * removed, so a temporary file that nobody has locked is stale, whatever pid its name carries
 * (the pid may be of another pid namespace: another container, another machine). */
#define _GNU_SOURCE
#include "opaline.h"
#include "file_inputs.h"

#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <pthread.h>
#include <semaphore.h>
#include <signal.h>
#include <stdlib.h>
#include <string.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <sys/xattr.h>
#include <time.h>
#include <unistd.h>

#define TEMP_TAG ".tmp-opaline-"
#define MAX_SYMLINKS 40
#define FRESH_SECONDS 10 /* an unlocked empty temporary file younger than this may be a writer's
                            that has not locked it yet (only where O_TMPFILE is not supported) */

/* How commit puts the data in place. */
typedef enum place {
    PLACE_RENAME,    /* the temporary file is renamed over dest */
    PLACE_COPY_PATH, /* copied into dest, opened for writing (a device, a FIFO, a file whose
                        attributes a new file cannot have) */
    PLACE_COPY_FD,   /* copied to the descriptor through_fd (/dev/stdout, /dev/fd/N) */
} place;

/* What a file name is to the same-file checks: an existing file (name NULL), or a name yet to
 * be made in the folder dev:ino. */
typedef struct identity {
    dev_t dev;
    ino_t ino;
    char *name;
} identity;

struct op_output {
    FILE *f;
    char *path;     /* as the caller named it */
    char *dest;     /* the file to replace or copy into (path, links followed) */
    char *tmp_path; /* the temporary file */
    place place;
    int through_fd;
    int has_id; /* id is set: a regular file or one to be made (not a device or descriptor) */
    identity id;
    int failed_errno;
    op_output *prev, *next; /* the live list */
    op_output *group_next;  /* the calling thread's group of outputs committed together */
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
    free(o->id.name);
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

/* The folder of path ("." when it has no slash, "/" for "/x") in dir[n]. */
static void folder_of(const char *path, char *dir, size_t n)
{
    const char *slash = strrchr(path, '/');
    if (!slash)
        snprintf(dir, n, ".");
    else
        snprintf(dir, n, "%.*s", slash == path ? 1 : (int)(slash - path), path);
}

/* The descriptor a path names (/dev/stdin, /dev/stdout, /dev/stderr, /dev/fd/N,
 * /proc/self/fd/N), or -1. Such a name is the descriptor the program was given, whatever it
 * refers to: a pipe, a socket, a terminal or a file opened by the shell's redirection. */
static int descriptor_named(const char *path)
{
    static const char *const std[] = {"/dev/stdin", "/dev/stdout", "/dev/stderr"};
    for (int i = 0; i < 3; i++)
        if (strcmp(path, std[i]) == 0)
            return i;
    const char *n = strncmp(path, "/dev/fd/", 8) == 0          ? path + 8
                    : strncmp(path, "/proc/self/fd/", 14) == 0 ? path + 14
                                                                : NULL;
    if (!n || *n < '0' || *n > '9')
        return -1;
    char *end;
    errno = 0;
    long fd = strtol(n, &end, 10);
    return errno || *end || fd > INT_MAX ? -1 : (int)fd;
}

/* Refuses (OP_ERR_IO) to follow the link at link (its lstat in lst) when it lies in a sticky
 * world-writable folder and belongs to neither the caller nor the folder's owner: another user
 * may have planted it there to make us write where they cannot. */
static op_status check_link_owner(const char *path, const char *link, const struct stat *lst,
                                  op_error *err)
{
    char dir[PATH_MAX];
    folder_of(link, dir, sizeof dir);
    struct stat ds;
    if (stat(dir, &ds) != 0 || !(ds.st_mode & S_ISVTX) || !(ds.st_mode & S_IWOTH) ||
        lst->st_uid == geteuid() || lst->st_uid == ds.st_uid)
        return OP_OK;
    int self = strcmp(link, path) == 0;
    return op_error_set(err, OP_ERR_IO, "%s: %s%s%s belongs to user %ld, in the sticky "
                        "world-writable folder %s of user %ld: not followed (the kernel's "
                        "protected_symlinks rule); remove the link or give another output name",
                        path, self ? "is a symbolic link that" : "leads through the symbolic link ",
                        self ? "" : link, self ? "" : ", which", (long)lst->st_uid, dir,
                        (long)ds.st_uid);
}

/* Follows the symbolic links at path (check_link_owner at each) to the file a write should
 * replace or create: *dest gets its malloc'ed path and *st its lstat (st_mode 0 when it does
 * not exist). */
static op_status resolve_destination(const char *path, char **dest, struct stat *st,
                                     op_error *err)
{
    *dest = NULL;
    char *cur = strdup(path);
    op_status status = OP_OK;
    for (int links = 0; cur && !status; links++) {
        if (lstat(cur, st) != 0) {
            if (errno != ENOENT)
                break;
            memset(st, 0, sizeof *st);
            *dest = cur;
            return OP_OK;
        }
        if (!S_ISLNK(st->st_mode)) {
            *dest = cur;
            return OP_OK;
        }
        if ((status = check_link_owner(path, cur, st, err)))
            break;
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
    if (status)
        return status;
    return op_error_set(err, e == ENOMEM ? OP_ERR_NOMEM : OP_ERR_IO, "%s: %s", path,
                        e == ENOMEM ? "out of memory" : strerror(e));
}

/* Fills o->id for the regular file or new name o->dest (st: its lstat, st_mode 0 when new).
 * Returns 0 or an errno (ENOENT: the folder does not exist). */
static int set_identity(op_output *o, const struct stat *st)
{
    if (st->st_mode) {
        o->id.dev = st->st_dev;
        o->id.ino = st->st_ino;
        o->has_id = 1;
        return 0;
    }
    char dir[PATH_MAX];
    folder_of(o->dest, dir, sizeof dir);
    struct stat ds;
    if (stat(dir, &ds) != 0)
        return errno;
    const char *slash = strrchr(o->dest, '/');
    if (!(o->id.name = strdup(slash ? slash + 1 : o->dest)))
        return ENOMEM;
    o->id.dev = ds.st_dev;
    o->id.ino = ds.st_ino;
    o->has_id = 1;
    return 0;
}

static int same_identity(const identity *a, const identity *b)
{
    return a->dev == b->dev && a->ino == b->ino &&
           (a->name ? b->name && strcmp(a->name, b->name) == 0 : !b->name);
}

/* Stale temporary files: "<base>.tmp-opaline-<pid>-XXXXXX" (prefix already matched: s points
 * after it)? */
static int temp_name(const char *s)
{
    if (*s < '0' || *s > '9')
        return 0;
    while (*s >= '0' && *s <= '9')
        s++;
    if (*s++ != '-' || strlen(s) != 6)
        return 0;
    for (; *s; s++)
        if (!((*s >= '0' && *s <= '9') || (*s >= 'a' && *s <= 'z') || (*s >= 'A' && *s <= 'Z')))
            return 0;
    return 1;
}

/* Removes the temporary files for temp_prefix (a path ending in TEMP_TAG) that no writer holds
 * locked (left by a process killed by SIGKILL, a power cut); never one a live writer holds,
 * whichever machine or container it runs in. */
static void remove_stale_temps(const char *temp_prefix)
{
    char dir[PATH_MAX];
    folder_of(temp_prefix, dir, sizeof dir);
    const char *slash = strrchr(temp_prefix, '/');
    const char *base = slash ? slash + 1 : temp_prefix;
    DIR *d = opendir(dir);
    if (!d)
        return;
    size_t bn = strlen(base);
    time_t now = time(NULL);
    struct dirent *e;
    while ((e = readdir(d))) {
        if (strncmp(e->d_name, base, bn) != 0 || !temp_name(e->d_name + bn))
            continue;
        int fd = openat(dirfd(d), e->d_name,
                        O_RDONLY | O_NOFOLLOW | O_NONBLOCK | O_NOCTTY | O_CLOEXEC);
        struct stat st;
        if (fd < 0)
            continue;
        if (fstat(fd, &st) == 0 && S_ISREG(st.st_mode) && flock(fd, LOCK_EX | LOCK_NB) == 0 &&
            (st.st_size > 0 || now - st.st_ctime > FRESH_SECONDS) &&
            unlinkat(dirfd(d), e->d_name, 0) == 0)
            op_log(OP_LOG_INFO, "removed %s%s%s: a temporary file left by an opaline run that is "
                   "no longer running (no process holds its lock)", dir,
                   strcmp(dir, "/") ? "/" : "", e->d_name);
        close(fd);
    }
    closedir(d);
}

/* Six random letters from the state *x. */
static void random_letters(uint64_t *x, char out[7])
{
    static const char letters[] = "abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789";
    for (int i = 0; i < 6; i++) {
        *x ^= *x << 13;
        *x ^= *x >> 7;
        *x ^= *x << 17;
        out[i] = letters[*x % (sizeof letters - 1)];
    }
    out[6] = '\0';
}

/* Gives the unnamed temporary file fd (O_TMPFILE) the name o->tmp_path; 0 or an errno. */
static int link_unnamed(int fd, const char *name)
{
    char self[64];
    snprintf(self, sizeof self, "/proc/self/fd/%d", fd);
    if (linkat(AT_FDCWD, self, AT_FDCWD, name, AT_SYMLINK_FOLLOW) == 0)
        return 0;
    int e = errno;
    /* Without /proc (a bare chroot), root may still name a descriptor directly. */
    return e != EEXIST && linkat(fd, "", AT_FDCWD, name, AT_EMPTY_PATH) == 0 ? 0 : e;
}

/* Creates o->tmp_path = temp_prefix + "<pid>-XXXXXX" (mode 0666 less the umask) and opens it
 * for reading and writing, locked (flock) before it has its name where the file system makes
 * unnamed files (O_TMPFILE), else just after; puts o on the live list. With live_lock held.
 * Returns 0 or an errno. */
static int create_temp_locked(op_output *o, const char *temp_prefix)
{
    size_t n = strlen(temp_prefix) + 32;
    if (!(o->tmp_path = malloc(n)))
        return ENOMEM;
    char dir[PATH_MAX];
    folder_of(temp_prefix, dir, sizeof dir);
    struct timespec ts;
    clock_gettime(CLOCK_REALTIME, &ts);
    uint64_t x = op_hash64((uint64_t)ts.tv_nsec ^ (uint64_t)(uintptr_t)o) | 1;
    int fd = open(dir, O_RDWR | O_TMPFILE | O_CLOEXEC, 0666);
    int unnamed = fd >= 0 && flock(fd, LOCK_EX) == 0, named = 0, e = EEXIST;
    if (fd >= 0 && !unnamed) {
        close(fd);
        fd = -1;
    }
    for (int tries = 0; e == EEXIST && tries < 100; tries++) {
        char rnd[7];
        random_letters(&x, rnd);
        snprintf(o->tmp_path, n, "%s%ld-%s", temp_prefix, (long)getpid(), rnd);
        if (unnamed) {
            e = link_unnamed(fd, o->tmp_path);
            if (e && e != EEXIST) { /* cannot be named: make a named file instead */
                close(fd);
                fd = -1;
                unnamed = 0;
                e = EEXIST;
            }
        } else {
            fd = open(o->tmp_path, O_RDWR | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
            e = fd < 0 ? errno : flock(fd, LOCK_EX) == 0 ? 0 : errno;
        }
        named = fd >= 0 && (e == 0 || !unnamed);
    }
    if (!e && !(o->f = fdopen(fd, "w+b")))
        e = errno;
    if (e) {
        if (named)
            unlink(o->tmp_path);
        if (fd >= 0)
            close(fd);
        return e;
    }
    live_add(o);
    return 0;
}

/* Gives o's temporary file the extended attributes of the file it replaces (ACLs among them,
 * and none that the folder's default ACL gave the new file and the old file lacks). Returns 0,
 * or an errno when one cannot be kept. */
static int keep_xattrs(op_output *o)
{
    int fd = fileno(o->f);
    ssize_t got = listxattr(o->dest, NULL, 0);
    if (got < 0)
        return errno == ENOTSUP ? 0 : errno;
    size_t n = (size_t)got;
    char *names = malloc(n + 1), *value = NULL;
    int e = names ? 0 : ENOMEM;
    if (!e && (got = listxattr(o->dest, names, n)) < 0)
        e = errno;
    n = e ? 0 : (size_t)got;
    if (!e && fgetxattr(fd, "system.posix_acl_access", NULL, 0) >= 0 &&
        !memmem(names, n, "system.posix_acl_access", sizeof "system.posix_acl_access"))
        e = fremovexattr(fd, "system.posix_acl_access") == 0 ? 0 : errno;
    for (size_t at = 0; !e && at < n; at += strlen(names + at) + 1) {
        const char *name = names + at;
        ssize_t size = getxattr(o->dest, name, NULL, 0);
        char *grown = size >= 0 ? realloc(value, (size_t)size + 1) : NULL;
        if (size < 0 || !grown) {
            e = size < 0 ? errno : ENOMEM;
            break;
        }
        value = grown;
        if ((size = getxattr(o->dest, name, value, (size_t)size)) < 0 ||
            fsetxattr(fd, name, value, (size_t)size, 0) != 0) {
            e = errno;
            op_log(OP_LOG_DEBUG, "%s: the extended attribute %s cannot be given to a new file: "
                   "%s", o->path, name, strerror(e));
        }
    }
    free(value);
    free(names);
    return e;
}

/* Gives o's temporary file the owner (when root: only root can give a file away), the extended
 * attributes and the permission bits of the file *st that it replaces. When the attributes cannot
 * all be kept (a security label only the old file may carry), the new data will be copied into
 * the old file instead. Returns 0 or an errno. */
static int keep_owner_and_mode(op_output *o, const struct stat *st)
{
    int fd = fileno(o->f);
    struct stat mine;
    if (geteuid() == 0 && fstat(fd, &mine) == 0 &&
        (mine.st_uid != st->st_uid || mine.st_gid != st->st_gid) &&
        fchown(fd, st->st_uid, st->st_gid) != 0)
        op_log(OP_LOG_WARN, "%s: cannot keep the owner %ld:%ld: %s", o->path, (long)st->st_uid,
               (long)st->st_gid, strerror(errno));
    int e = keep_xattrs(o);
    if (e == ENOMEM)
        return e;
    if (e) {
        op_log(OP_LOG_INFO, "%s: its extended attributes cannot be given to a new file (%s): "
               "it is written in place", o->path, strerror(e));
        o->place = PLACE_COPY_PATH;
        return 0;
    }
    return fchmod(fd, st->st_mode & 07777) == 0 ? 0 : errno;
}

/* Fills o->dest, o->place (and o->through_fd) and o->id for o->path, and *st with the
 * destination's lstat when it is a regular file (st_mode 0 otherwise); refuses what cannot be
 * written. */
static op_status examine(op_output *o, struct stat *st, op_error *err)
{
    memset(st, 0, sizeof *st);
    int fd = descriptor_named(o->path);
    struct stat ts;
    if (fd >= 0) {
        if (fstat(fd, &ts) != 0)
            return op_error_set(err, OP_ERR_IO, "%s: descriptor %d is not open", o->path, fd);
        o->place = PLACE_COPY_FD;
        o->through_fd = fd;
    } else {
        op_status status = resolve_destination(o->path, &o->dest, st, err);
        if (status)
            return status;
        /* stat follows links as open does (also /proc's magic links: one to a pipe is a FIFO) */
        if (stat(o->path, &ts) != 0)
            ts.st_mode = 0;
        if (ts.st_mode && !S_ISREG(ts.st_mode)) { /* written through at commit, as opened */
            free(o->dest);
            if (!(o->dest = strdup(o->path)))
                return op_error_set(err, OP_ERR_NOMEM, "%s: out of memory", o->path);
            o->place = PLACE_COPY_PATH;
            memset(st, 0, sizeof *st);
        }
    }
    const char *kind = S_ISDIR(ts.st_mode)    ? "a directory"
                       : S_ISBLK(ts.st_mode)  ? "a block device"
                       : S_ISSOCK(ts.st_mode) ? "a socket"
                       : !ts.st_mode || S_ISREG(ts.st_mode) || S_ISCHR(ts.st_mode) ||
                               S_ISFIFO(ts.st_mode)
                           ? NULL
                           : "not a regular file";
    if (kind && o->place != PLACE_COPY_FD)
        return op_error_set(err, OP_ERR_IO, "%s: is %s; opaline writes regular files, and "
                            "through to character devices (such as /dev/null) and FIFOs",
                            o->path, kind);
    if (o->place == PLACE_COPY_FD && S_ISDIR(ts.st_mode))
        return op_error_set(err, OP_ERR_IO, "%s: descriptor %d is a directory", o->path, fd);
    int e = o->place == PLACE_RENAME ? set_identity(o, st) : 0;
    if (e == ENOENT || e == ENOTDIR) {
        char dir[PATH_MAX];
        folder_of(o->dest, dir, sizeof dir);
        return op_error_set(err, OP_ERR_IO, "%s: cannot create it: the folder %s does not exist",
                            o->path, dir);
    }
    if (e)
        return op_error_set(err, e == ENOMEM ? OP_ERR_NOMEM : OP_ERR_IO, "%s: %s", o->path,
                            e == ENOMEM ? "out of memory" : strerror(e));
    return OP_OK;
}

/* Refuses (OP_ERR_INPUT) an output that is an input of this run (op_file_protect_inputs) or
 * the destination of another output being written. With live_lock held. */
static op_status check_distinct(const op_output *o, int may_be_input, op_error *err)
{
    if (!o->has_id)
        return OP_OK;
    char input[PATH_MAX];
    if (!may_be_input && !o->id.name && op_file_input_path(o->id.dev, o->id.ino, input, sizeof input))
        return op_error_set(err, OP_ERR_INPUT, "%s: is the input %s of this run (the same file); "
                            "refusing to replace it (give another output name)", o->path, input);
    for (const op_output *p = live_head; p; p = p->next)
        if (p != o && p->has_id && same_identity(&p->id, &o->id))
            return op_error_set(err, OP_ERR_INPUT, "%s: is the same file as the output %s of "
                                "this run; give each output its own name", o->path, p->path);
    return OP_OK;
}

static op_status output_open(const char *path, int may_be_input, op_output **out, op_error *err)
{
    *out = NULL;
    op_output *o = calloc(1, sizeof *o);
    if (!o || !(o->path = strdup(path))) {
        free(o);
        return op_error_set(err, OP_ERR_NOMEM, "%s: out of memory", path);
    }
    o->through_fd = -1;
    struct stat st;
    op_status status = examine(o, &st, err);
    if (status) {
        output_free(o);
        return status;
    }
    char *temp_prefix = NULL;
    const char *tmpdir = getenv("TMPDIR");
    int in_tmpdir = o->place != PLACE_RENAME;
    if (in_tmpdir) { /* written through at commit; until then the data waits in $TMPDIR */
        const char *slash = strrchr(path, '/');
        if (!tmpdir || !tmpdir[0])
            tmpdir = "/tmp";
        if (asprintf(&temp_prefix, "%s/%s%s", tmpdir, slash ? slash + 1 : path, TEMP_TAG) < 0)
            temp_prefix = NULL;
    } else if (asprintf(&temp_prefix, "%s%s", o->dest, TEMP_TAG) < 0) {
        temp_prefix = NULL;
    }
    int e = temp_prefix ? 0 : ENOMEM;
    if (!e) {
        remove_stale_temps(temp_prefix);
        pthread_mutex_lock(&live_lock);
        status = check_distinct(o, may_be_input, err);
        e = status ? 0 : create_temp_locked(o, temp_prefix);
        pthread_mutex_unlock(&live_lock);
    }
    free(temp_prefix);
    if (!status && !e && o->place == PLACE_RENAME && S_ISREG(st.st_mode))
        e = keep_owner_and_mode(o, &st);
    if (!status && e) {
        if (e == ENOMEM)
            status = op_error_set(err, OP_ERR_NOMEM, "%s: out of memory", path);
        else if (in_tmpdir)
            status = op_error_set(err, OP_ERR_IO, "%s: cannot create its temporary file in "
                                  "$TMPDIR (%s): %s", path, tmpdir, strerror(e));
        else
            status = op_error_set(err, OP_ERR_IO, "%s: cannot create%s%s: %s", path,
                                  strcmp(o->dest, path) ? " the link's target " : "",
                                  strcmp(o->dest, path) ? o->dest : "", strerror(e));
    }
    if (status) {
        if (o->f)
            op_output_abort(o);
        else
            output_free(o);
        return status;
    }
    *out = o;
    return OP_OK;
}

op_status op_output_open(const char *path, op_output **out, op_error *err)
{
    return output_open(path, 0, out, err);
}

op_status op_output_open_update(const char *path, op_output **out, op_error *err)
{
    return output_open(path, 1, out, err);
}

op_status op_output_check(const char *const *outputs, int n, const char *const *inputs, int m,
                          op_error *err)
{
    op_output **open = calloc((size_t)(n > 0 ? n : 1), sizeof *open);
    if (!open)
        return op_error_set(err, OP_ERR_NOMEM, "out of memory");
    op_status status = OP_OK;
    for (int i = 0; i < n && !status; i++)
        status = op_output_open(outputs[i], &open[i], err);
    for (int j = 0; j < m && !status; j++) {
        struct stat st;
        if (!inputs[j] || stat(inputs[j], &st) != 0 || !S_ISREG(st.st_mode))
            continue;
        identity in = {st.st_dev, st.st_ino, NULL};
        for (int i = 0; i < n && !status; i++)
            if (open[i]->has_id && same_identity(&open[i]->id, &in))
                status = op_error_set(err, OP_ERR_INPUT, "%s: is the input %s (the same file); "
                                      "refusing to replace it (give another output name)",
                                      outputs[i], inputs[j]);
    }
    for (int i = 0; i < n; i++)
        op_output_abort(open[i]);
    free(open);
    return status;
}

/* What a failed write's errno means to the user. */
static const char *write_error_text(int e)
{
    return e == EFBIG ? "the file size limit was reached (ulimit -f)" : strerror(e);
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
                            write_error_text(out->failed_errno));
    *tmp_path = out->tmp_path;
    return OP_OK;
}

/* Copies the temporary file's contents to out->dest (opened for writing: a device, a FIFO, a
 * file written in place) or to out->through_fd; returns 0 or errno. */
static int copy_through(op_output *out)
{
    int in = fileno(out->f);
    if (lseek(in, 0, SEEK_SET) != 0)
        return errno;
    int fd = out->place == PLACE_COPY_FD
                 ? out->through_fd
                 : open(out->dest, O_WRONLY | O_TRUNC | O_NOCTTY | O_CLOEXEC);
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
    if (out->place != PLACE_COPY_FD && close(fd) != 0 && !e && errno != EINTR)
        e = errno;
    return e;
}

/* The data is all written and on disk (for a file renamed into place); 0 or an errno. */
static int complete(op_output *out)
{
    int e = out->failed_errno;
    if (!e && (fflush(out->f) != 0 || ferror(out->f)))
        e = errno ? errno : EIO;
    if (!e && out->place == PLACE_RENAME && fsync(fileno(out->f)) != 0)
        e = errno;
    return e;
}

/* Puts a complete output in place (e == 0) or drops it, and frees it. The temporary file is
 * renamed while still open and locked, so no cleaner takes it for stale. */
static op_status finish(op_output *out, int e, op_error *err)
{
    if (!e && out->place != PLACE_RENAME)
        e = copy_through(out);
    pthread_mutex_lock(&live_lock);
    if (!e && out->place == PLACE_RENAME && rename(out->tmp_path, out->dest) != 0)
        e = errno;
    if (e || out->place != PLACE_RENAME)
        unlink(out->tmp_path);
    live_remove(out);
    pthread_mutex_unlock(&live_lock);
    fclose(out->f); /* flushed: nothing can fail here that was not reported */
    op_status st = OP_OK;
    if (e)
        st = op_error_set(err, e == ENOMEM ? OP_ERR_NOMEM : OP_ERR_IO, "%s: cannot write: %s",
                          out->path, write_error_text(e));
    output_free(out);
    return st;
}

/* The calling thread's group (op_output_group_begin): outputs committed but not yet in place,
 * in the order of their commits. */
static _Thread_local int grouping;
static _Thread_local op_output *group_head;

op_status op_output_commit(op_output *out, op_error *err)
{
    int e = complete(out);
    if (e || !grouping)
        return finish(out, e, err);
    op_output **tail = &group_head;
    while (*tail)
        tail = &(*tail)->group_next;
    out->group_next = NULL;
    *tail = out;
    return OP_OK;
}

void op_output_abort(op_output *out)
{
    if (!out)
        return;
    pthread_mutex_lock(&live_lock);
    unlink(out->tmp_path);
    live_remove(out);
    pthread_mutex_unlock(&live_lock);
    fclose(out->f);
    output_free(out);
}

void op_output_group_begin(void)
{
    grouping = 1;
}

op_status op_output_group_commit(op_error *err)
{
    grouping = 0;
    op_status st = OP_OK;
    /* Those copied through first: data sent to a device cannot be taken back, a rename not yet
     * made can. */
    for (int pass = 0; pass < 2; pass++)
        for (op_output **p = &group_head, *o; (o = *p);) {
            if ((o->place == PLACE_RENAME) != pass) {
                p = &o->group_next;
                continue;
            }
            *p = o->group_next;
            if (st)
                op_output_abort(o);
            else
                st = finish(o, 0, err);
        }
    return st;
}

void op_output_group_abort(void)
{
    grouping = 0;
    for (op_output *o = group_head, *next; o; o = next) {
        next = o->group_next;
        op_output_abort(o);
    }
    group_head = NULL;
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
    signal(SIGXFSZ, SIG_IGN); /* a file over `ulimit -f` is then a write error, EFBIG */
    return OP_OK;
}
