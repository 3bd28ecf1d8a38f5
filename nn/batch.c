/* Mini-batch order and gathering for training loops over an in-memory data set. */
#include <string.h>

#include "nn/nn.h"

/* splitmix64's finaliser: a bijection of 64-bit words, so hashing a (seed, counter) pair
 * gives counter-based random bits: any draw is computable alone, in any order or thread. */
uint64_t nn_mix64(uint64_t z)
{
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
}

void nn_epoch_order(uint64_t seed, long long epoch, int shuffle, size_t n, size_t *order)
{
    for (size_t i = 0; i < n; i++)
        order[i] = i;
    if (!shuffle)
        return;
    // Fisher-Yates from the back; draw k is a pure function of (seed, epoch, k), so the
    // order of any epoch can be rebuilt without replaying the ones before it (resuming)
    uint64_t s = nn_mix64(seed ^ nn_mix64((uint64_t)epoch + 0x510e527fade682d1ull));
    for (size_t i = n - 1; i > 0 && n > 1; i--) {
        uint64_t r = nn_mix64(s + i);
        size_t j = (size_t)(r % (uint64_t)(i + 1)); /* bias < (i+1) / 2^64: none visible */
        size_t t = order[i];
        order[i] = order[j];
        order[j] = t;
    }
}

void nn_gather_rows(float *dst, const float *src, size_t cols, const size_t *rows, size_t n)
{
    for (size_t i = 0; i < n; i++)
        memcpy(dst + i * cols, src + rows[i] * cols, cols * sizeof(float));
}

void nn_step_batch(long long step, size_t n_rows, int batch, long long *epoch, size_t *first,
                   int *count)
{
    // an epoch is ceil(n / batch) steps; its last batch may be short (torch's DataLoader
    // with drop_last=False)
    long long per_epoch = (long long)((n_rows + (size_t)batch - 1) / (size_t)batch);
    *epoch = step / per_epoch;
    *first = (size_t)(step % per_epoch) * (size_t)batch;
    size_t left = n_rows - *first;
    *count = left < (size_t)batch ? (int)left : batch;
}
