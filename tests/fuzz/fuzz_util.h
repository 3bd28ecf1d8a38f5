/* Helpers shared by the libFuzzer harnesses (tests/fuzz/README.md).
 *
 * Several parsers take a path, not a buffer (nn_safetensors_open, nn_npy_read_f32,
 * forest_load, image_read, dataset_open, predictor_load): those harnesses write each input
 * to a file of this process (fuzz_temp_path), so parallel fuzzers (-jobs, -fork) and CI
 * runs never share one, and the file is removed at exit. */
#ifndef IMSYNTH_FUZZ_UTIL_H
#define IMSYNTH_FUZZ_UTIL_H
#include <stddef.h>
#include <stdint.h>

/* "$TMPDIR/imsynth-fuzz-<pid>-<name>" (TMPDIR defaults to /tmp) into buf; the file or
 * directory of that name is deleted at exit (recursively for a directory). Returns buf. */
char *fuzz_temp_path(char *buf, size_t len, const char *name);

/* Write n bytes to path, replacing it. 0, or -1 (then the input is skipped). */
int fuzz_write_file(const char *path, const uint8_t *data, size_t n);

#endif
