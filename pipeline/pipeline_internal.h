/* Private to pipeline/: helpers its files share. */
#ifndef IMSYNTH_PIPELINE_INTERNAL_H
#define IMSYNTH_PIPELINE_INTERNAL_H

#include <stddef.h>
#include <stdint.h>

#include "pipeline/pipeline.h"

/* Formats a message into err (if not NULL); returns -1 for chaining. */
int pipeline_error(char *err, size_t errlen, const char *fmt, ...)
    __attribute__((format(printf, 3, 4)));

/* Seconds on the monotonic clock. */
double pipeline_now(void);

/* Reads a whole file (NUL-terminated; *len excludes the NUL). NULL with a message. */
char *pipeline_read_file(const char *path, size_t *len, char *err, size_t errlen);

/* SHA-256, incrementally (sha256.c). */
typedef struct sha256_ctx {
    uint32_t h[8];
    uint64_t length; /* bytes so far */
    unsigned char block[64];
    size_t fill;
} sha256_ctx;
void sha256_init(sha256_ctx *c);
void sha256_update(sha256_ctx *c, const void *data, size_t len);
void sha256_final_hex(sha256_ctx *c, char out[65]);

#endif
