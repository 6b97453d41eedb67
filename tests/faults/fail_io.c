// LD_PRELOAD shim for the fault-injection campaign: fails the Nth write/fsync/close/rename-type call on files under one directory.
//
// Environment:
//   VOLCL_FAIL_DIR    only calls on files in or below this directory count (fd paths resolved through
//                     /proc/self/fd, so an O_TMPFILE "/dir/#123 (deleted)" counts as under /dir)
//   VOLCL_FAIL_CALL   the call family to fail: write (write, pwrite, writev, pwritev, fwrite), fsync
//                     (fsync, fdatasync, fflush), close (close, fclose), rename (rename, renameat,
//                     renameat2), link (linkat, link); or one exact name (pwrite, writev, fdatasync, ...)
//   VOLCL_FAIL_AT     N: the Nth counted call fails (1-based); 0 or unset: none fails, calls are only counted
//   VOLCL_FAIL_ERRNO  ENOSPC (default), EIO, EDQUOT, EFBIG
//   VOLCL_FAIL_STICKY 1: every counted call from the Nth on fails (a disk that stays full)
//   VOLCL_FAIL_SIGNAL KILL or TERM: instead of failing the Nth call, the process sends itself that signal
//                     just before it (a kill at an exact point of the write protocol)
//   VOLCL_FAIL_COUNT_FILE  when set, each family's count of calls on files under the directory is appended
//                     there at exit as "FAMILY N" lines (calibration; VOLCL_FAIL_CALL may be "count" then)
// A failed close or fclose still releases the descriptor, as Linux does when close reports an error.
#define _GNU_SOURCE
#include <dlfcn.h>
#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <signal.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/types.h>
#include <sys/uio.h>
#include <unistd.h>

static char g_dir[PATH_MAX];
static size_t g_dirLen;
static char g_call[32];
static long g_failAt;
static int g_errno = ENOSPC;
static int g_sticky;
static int g_signal;
static atomic_long g_count;
static const char* const kFamilies[] = {"write", "fsync", "close", "rename", "link"};
static atomic_long g_familyCount[5];
static int g_ready;

static void writeCountAtExit(void) {
    const char* file = getenv("VOLCL_FAIL_COUNT_FILE");
    if (!file || !*file) return;
    FILE* f = fopen(file, "a");
    if (!f) return;
    for (int i = 0; i < 5; ++i)
        fprintf(f, "%s %ld\n", kFamilies[i], atomic_load(&g_familyCount[i]));
    fclose(f);
}

__attribute__((constructor)) static void failIoInit(void) {
    const char* dir = getenv("VOLCL_FAIL_DIR");
    const char* call = getenv("VOLCL_FAIL_CALL");
    if (!dir || !*dir || !call || !*call) return;
    if (!realpath(dir, g_dir)) return;
    g_dirLen = strlen(g_dir);
    snprintf(g_call, sizeof g_call, "%s", call);
    const char* at = getenv("VOLCL_FAIL_AT");
    g_failAt = at ? atol(at) : 0;
    const char* e = getenv("VOLCL_FAIL_ERRNO");
    if (e && strcmp(e, "EIO") == 0)
        g_errno = EIO;
    else if (e && strcmp(e, "EDQUOT") == 0)
        g_errno = EDQUOT;
    else if (e && strcmp(e, "EFBIG") == 0)
        g_errno = EFBIG;
    const char* sticky = getenv("VOLCL_FAIL_STICKY");
    g_sticky = sticky && strcmp(sticky, "1") == 0;
    const char* sig = getenv("VOLCL_FAIL_SIGNAL");
    if (sig && strcmp(sig, "KILL") == 0)
        g_signal = SIGKILL;
    else if (sig && strcmp(sig, "TERM") == 0)
        g_signal = SIGTERM;
    g_ready = 1;
    atexit(writeCountAtExit);
}

// The family a call belongs to, so that VOLCL_FAIL_CALL=write covers write, pwrite, writev and fwrite.
static const char* familyOf(const char* name) {
    if (!strcmp(name, "write") || !strcmp(name, "pwrite") || !strcmp(name, "writev") ||
        !strcmp(name, "pwritev") || !strcmp(name, "fwrite"))
        return "write";
    if (!strcmp(name, "fsync") || !strcmp(name, "fdatasync") || !strcmp(name, "fflush")) return "fsync";
    if (!strcmp(name, "close") || !strcmp(name, "fclose")) return "close";
    if (!strcmp(name, "rename") || !strcmp(name, "renameat") || !strcmp(name, "renameat2")) return "rename";
    if (!strcmp(name, "linkat") || !strcmp(name, "link")) return "link";
    return name;
}

static int underDir(const char* path) {
    return strncmp(path, g_dir, g_dirLen) == 0 && (path[g_dirLen] == '/' || path[g_dirLen] == '\0');
}

static int fdUnderDir(int fd) {
    char link[64], path[PATH_MAX];
    snprintf(link, sizeof link, "/proc/self/fd/%d", fd);
    const ssize_t n = readlink(link, path, sizeof path - 1);
    if (n <= 0) return 0;
    path[n] = '\0';
    return underDir(path);
}

// A path argument resolved as far as it exists: the target of a rename may not exist yet, so its
// directory is resolved and the name appended. /proc/self/fd/N names resolve to the open file.
static int pathUnderDir(int dirfd, const char* p) {
    if (!p) return 0;
    char full[PATH_MAX], resolved[PATH_MAX];
    if (p[0] == '/') {
        snprintf(full, sizeof full, "%s", p);
    } else {
        char base[PATH_MAX / 2];
        if (dirfd == AT_FDCWD) {
            if (!getcwd(base, sizeof base)) return 0;
        } else {
            char link[64];
            snprintf(link, sizeof link, "/proc/self/fd/%d", dirfd);
            const ssize_t n = readlink(link, base, sizeof base - 1);
            if (n <= 0) return 0;
            base[n] = '\0';
        }
        snprintf(full, sizeof full, "%s/%s", base, p);
    }
    if (realpath(full, resolved)) return underDir(resolved);
    char* slash = strrchr(full, '/');
    if (!slash) return 0;
    *slash = '\0';
    if (!realpath(full[0] ? full : "/", resolved)) return 0;
    return underDir(resolved);
}

// Counts a call on a file under the directory; true when this one must fail.
static int shouldFail(const char* name, int under) {
    if (!g_ready || !under) return 0;
    const char* family = familyOf(name);
    for (int i = 0; i < 5; ++i)
        if (!strcmp(family, kFamilies[i])) atomic_fetch_add(&g_familyCount[i], 1);
    if (strcmp(g_call, name) != 0 && strcmp(g_call, family) != 0) return 0;
    const long n = atomic_fetch_add(&g_count, 1) + 1;
    if (g_failAt <= 0) return 0;
    if (g_signal) {
        if (n == g_failAt) kill(getpid(), g_signal);
        return 0;
    }
    return g_sticky ? n >= g_failAt : n == g_failAt;
}

#define REAL(ret, name, ...)                                                                                 \
    static ret (*real_##name)(__VA_ARGS__);                                                                  \
    if (!real_##name) real_##name = (ret(*)(__VA_ARGS__))dlsym(RTLD_NEXT, #name)

ssize_t write(int fd, const void* buf, size_t count) {
    REAL(ssize_t, write, int, const void*, size_t);
    if (shouldFail("write", g_ready && fdUnderDir(fd))) return errno = g_errno, -1;
    return real_write(fd, buf, count);
}

ssize_t pwrite(int fd, const void* buf, size_t count, off_t offset) {
    REAL(ssize_t, pwrite, int, const void*, size_t, off_t);
    if (shouldFail("pwrite", g_ready && fdUnderDir(fd))) return errno = g_errno, -1;
    return real_pwrite(fd, buf, count, offset);
}

ssize_t pwrite64(int fd, const void* buf, size_t count, off_t offset) {
    REAL(ssize_t, pwrite64, int, const void*, size_t, off_t);
    if (shouldFail("pwrite", g_ready && fdUnderDir(fd))) return errno = g_errno, -1;
    return real_pwrite64(fd, buf, count, offset);
}

ssize_t writev(int fd, const struct iovec* iov, int iovcnt) {
    REAL(ssize_t, writev, int, const struct iovec*, int);
    if (shouldFail("writev", g_ready && fdUnderDir(fd))) return errno = g_errno, -1;
    return real_writev(fd, iov, iovcnt);
}

ssize_t pwritev(int fd, const struct iovec* iov, int iovcnt, off_t offset) {
    REAL(ssize_t, pwritev, int, const struct iovec*, int, off_t);
    if (shouldFail("pwritev", g_ready && fdUnderDir(fd))) return errno = g_errno, -1;
    return real_pwritev(fd, iov, iovcnt, offset);
}

// stdio's own flushes call glibc's internal write, which LD_PRELOAD cannot reach: fwrite, fflush and
// fclose are failed at their own level instead (zlib's gz*, libpng and OpenImageIO write through them).
size_t fwrite(const void* ptr, size_t size, size_t n, FILE* f) {
    REAL(size_t, fwrite, const void*, size_t, size_t, FILE*);
    if (shouldFail("fwrite", g_ready && fdUnderDir(fileno(f)))) return errno = g_errno, 0;
    return real_fwrite(ptr, size, n, f);
}

int fflush(FILE* f) {
    REAL(int, fflush, FILE*);
    if (shouldFail("fflush", g_ready && f && fdUnderDir(fileno(f)))) return errno = g_errno, EOF;
    return real_fflush(f);
}

int fclose(FILE* f) {
    REAL(int, fclose, FILE*);
    const int fail = shouldFail("fclose", g_ready && fdUnderDir(fileno(f)));
    const int rc = real_fclose(f);
    if (fail) return errno = g_errno, EOF;
    return rc;
}

int fsync(int fd) {
    REAL(int, fsync, int);
    if (shouldFail("fsync", g_ready && fdUnderDir(fd))) return errno = g_errno, -1;
    return real_fsync(fd);
}

int fdatasync(int fd) {
    REAL(int, fdatasync, int);
    if (shouldFail("fdatasync", g_ready && fdUnderDir(fd))) return errno = g_errno, -1;
    return real_fdatasync(fd);
}

int close(int fd) {
    REAL(int, close, int);
    const int fail = shouldFail("close", g_ready && fdUnderDir(fd));
    const int rc = real_close(fd);
    if (fail) return errno = g_errno, -1;
    return rc;
}

int rename(const char* oldpath, const char* newpath) {
    REAL(int, rename, const char*, const char*);
    const int under = g_ready && (pathUnderDir(AT_FDCWD, oldpath) || pathUnderDir(AT_FDCWD, newpath));
    if (shouldFail("rename", under)) return errno = g_errno, -1;
    return real_rename(oldpath, newpath);
}

int renameat(int olddirfd, const char* oldpath, int newdirfd, const char* newpath) {
    REAL(int, renameat, int, const char*, int, const char*);
    const int under = g_ready && (pathUnderDir(olddirfd, oldpath) || pathUnderDir(newdirfd, newpath));
    if (shouldFail("renameat", under)) return errno = g_errno, -1;
    return real_renameat(olddirfd, oldpath, newdirfd, newpath);
}

int renameat2(int olddirfd, const char* oldpath, int newdirfd, const char* newpath, unsigned int flags) {
    REAL(int, renameat2, int, const char*, int, const char*, unsigned int);
    const int under = g_ready && (pathUnderDir(olddirfd, oldpath) || pathUnderDir(newdirfd, newpath));
    if (shouldFail("renameat2", under)) return errno = g_errno, -1;
    return real_renameat2(olddirfd, oldpath, newdirfd, newpath, flags);
}

int linkat(int olddirfd, const char* oldpath, int newdirfd, const char* newpath, int flags) {
    REAL(int, linkat, int, const char*, int, const char*, int);
    if (shouldFail("linkat", g_ready && pathUnderDir(newdirfd, newpath))) return errno = g_errno, -1;
    return real_linkat(olddirfd, oldpath, newdirfd, newpath, flags);
}

int link(const char* oldpath, const char* newpath) {
    REAL(int, link, const char*, const char*);
    if (shouldFail("link", g_ready && pathUnderDir(AT_FDCWD, newpath))) return errno = g_errno, -1;
    return real_link(oldpath, newpath);
}
