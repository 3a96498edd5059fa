/* io_file.c: atomic file output and whole-file input (io.h, "Atomic output").
 *
 * A writer never touches <path> itself: it writes "<path>.tmp.<pid>.<n>" in the same directory,
 * flushes and fsyncs it, closes it and renames it onto <path>. rename(2) within one file system
 * is atomic, so a reader sees either the old file or the complete new one. On any failure the
 * temporary file is unlinked and <path> is left as it was.
 */
#include "io.h"

#include <errno.h>
#include <limits.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/types.h>
#include <unistd.h>

/* Unique within the process; the pid makes it unique across processes. */
static atomic_uint g_temp_counter;

obs_status io_temp_path(obs_context *ctx, const char *path, char *tmp, size_t tmp_size)
{
    if (!path || !tmp || tmp_size == 0 || !path[0])
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "io_temp_path: NULL or empty argument");
    unsigned n = atomic_fetch_add(&g_temp_counter, 1u);
    int w = snprintf(tmp, tmp_size, "%s.tmp.%ld.%u", path, (long)getpid(), n);
    if (w < 0 || (size_t)w >= tmp_size) {
        tmp[0] = '\0';
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT,
                         "io_temp_path: buffer of %zu bytes too small for a temporary name beside '%s'",
                         tmp_size, path);
    }
    return OBS_STATUS_OK;
}

obs_status io_commit_temp(obs_context *ctx, const char *tmp, const char *path)
{
    if (!tmp || !path)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "io_commit_temp: NULL argument");
    if (rename(tmp, path) != 0) {
        int e = errno;
        unlink(tmp);
        return obs_error(ctx, OBS_STATUS_IO_ERROR, "cannot rename '%s' to '%s': %s", tmp, path, strerror(e));
    }
    return OBS_STATUS_OK;
}

obs_status io_write_file_atomic(obs_context *ctx, const char *path, const void *data, size_t len)
{
    if (!path || !path[0] || (!data && len > 0))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "io_write_file_atomic: NULL or empty argument");

    size_t plen = strlen(path);
    size_t tsize = plen + 48;
    char *tmp = malloc(tsize);
    if (!tmp)
        return obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "cannot allocate a temporary name for '%s'", path);
    obs_status st = io_temp_path(ctx, path, tmp, tsize);
    if (st != OBS_STATUS_OK) {
        free(tmp);
        return st;
    }

    FILE *f = fopen(tmp, "wb");
    if (!f) {
        int e = errno;
        st = obs_error(ctx, OBS_STATUS_IO_ERROR, "cannot write '%s' (creating '%s'): %s", path, tmp, strerror(e));
        free(tmp);
        return st;
    }

    int e = 0;
    const char *what = NULL;
    if (len > 0 && fwrite(data, 1, len, f) != len) {
        e = errno;
        what = "write";
    } else if (fflush(f) != 0) {
        e = errno;
        what = "flush";
    } else if (fsync(fileno(f)) != 0) {
        e = errno;
        what = "fsync";
    }
    if (fclose(f) != 0 && !what) {
        e = errno;
        what = "close";
    }
    if (what) {
        unlink(tmp);
        st = obs_error(ctx, OBS_STATUS_IO_ERROR, "cannot write '%s' (%s of '%s' failed): %s", path, what, tmp,
                       strerror(e ? e : EIO));
        free(tmp);
        return st;
    }
    if (rename(tmp, path) != 0) {
        e = errno;
        unlink(tmp);
        st = obs_error(ctx, OBS_STATUS_IO_ERROR, "cannot write '%s' (rename from '%s' failed): %s", path, tmp,
                       strerror(e));
        free(tmp);
        return st;
    }
    free(tmp);
    return OBS_STATUS_OK;
}

obs_status io_read_file(obs_context *ctx, const char *path, size_t max_bytes, char **data, size_t *len)
{
    if (data)
        *data = NULL;
    if (len)
        *len = 0;
    if (!path || !data || !len)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "io_read_file: NULL argument");

    FILE *f = fopen(path, "rb");
    if (!f) {
        int e = errno;
        return obs_error(ctx, OBS_STATUS_IO_ERROR, "cannot open '%s': %s", path, strerror(e));
    }
    struct stat sb;
    if (fstat(fileno(f), &sb) != 0) {
        int e = errno;
        fclose(f);
        return obs_error(ctx, OBS_STATUS_IO_ERROR, "cannot stat '%s': %s", path, strerror(e));
    }
    if (!S_ISREG(sb.st_mode)) {
        fclose(f);
        return obs_error(ctx, OBS_STATUS_IO_ERROR, "cannot read '%s': %s", path,
                         S_ISDIR(sb.st_mode) ? strerror(EISDIR) : "not a regular file");
    }
    if (sb.st_size < 0 || (uint64_t)sb.st_size > (uint64_t)max_bytes || (uint64_t)sb.st_size >= (uint64_t)SIZE_MAX) {
        fclose(f);
        return obs_error(ctx, OBS_STATUS_LIMIT_EXCEEDED, "'%s' is %lld bytes, over the limit of %zu bytes", path,
                         (long long)sb.st_size, max_bytes);
    }
    size_t size = (size_t)sb.st_size;
    char *buf = malloc(size + 1);
    if (!buf) {
        fclose(f);
        return obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "cannot allocate %zu bytes to read '%s'", size + 1, path);
    }
    size_t got = size > 0 ? fread(buf, 1, size, f) : 0;
    if (got != size || ferror(f)) {
        int e = errno;
        int was_error = ferror(f);
        free(buf);
        fclose(f);
        return obs_error(ctx, OBS_STATUS_IO_ERROR, "cannot read '%s': %s", path,
                         was_error ? strerror(e ? e : EIO) : "file shrank while reading");
    }
    /* The file may have grown since fstat: refuse rather than return a truncated view. */
    if (fgetc(f) != EOF) {
        free(buf);
        fclose(f);
        return obs_error(ctx, OBS_STATUS_IO_ERROR, "cannot read '%s': file grew while reading", path);
    }
    fclose(f);
    buf[size] = '\0';
    *data = buf;
    *len = size;
    return OBS_STATUS_OK;
}

obs_status io_make_dirs(obs_context *ctx, const char *dir)
{
    char buf[4096];
    size_t n = strlen(dir);
    if (n >= sizeof buf)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "directory name too long: %.64s...", dir);
    memcpy(buf, dir, n + 1);
    for (char *p = buf + 1; *p; p++) {
        if (*p != '/')
            continue;
        *p = '\0';
        if (mkdir(buf, 0777) != 0 && errno != EEXIST)
            return obs_error(ctx, OBS_STATUS_IO_ERROR, "cannot create directory %s: %s", buf, strerror(errno));
        *p = '/';
    }
    if (buf[0] && mkdir(buf, 0777) != 0 && errno != EEXIST)
        return obs_error(ctx, OBS_STATUS_IO_ERROR, "cannot create directory %s: %s", buf, strerror(errno));
    return OBS_STATUS_OK;
}
