/* fuzz_npy: NumPy .npy arrays (forest fit --x/--y, descriptor masks, test fixtures)
 * through nn_npy_read_f32: magic, version 1-3 header length, the header dict (descr,
 * fortran_order, shape), and the data size checked against the header before allocation. */
#include <stdint.h>
#include <stdlib.h>

#include "fuzz_util.h"
#include "nn/nn.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    char path[512], err[512];
    fuzz_temp_path(path, sizeof path, "input.npy");
    if (fuzz_write_file(path, data, size) != 0)
        return 0;
    float *values = NULL;
    size_t rows = 0, cols = 0;
    if (nn_npy_read_f32(path, &values, &rows, &cols, err, sizeof err) == 0) {
        /* Touch every value: the claimed shape must be what was allocated (ASan checks). */
        volatile float sum = 0.0f;
        for (size_t i = 0; i < rows * cols; i++)
            sum += values[i];
        (void)sum;
    } else if (values) {
        abort(); /* the reader promises *data == NULL on error */
    }
    free(values);
    return 0;
}
