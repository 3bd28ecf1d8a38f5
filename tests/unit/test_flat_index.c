/*
 * The flat graph's link index (shadergraph/flat.h) against a fresh one, through long runs
 * of the only two link edits, on the super-shader flattened. Extraction asserts the same
 * after every round, but only in debug builds; this runs in every build. And the checker
 * itself must be able to say no: a corrupted index is caught.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include "shadergraph/flat.h"
#include "test_assets.h"

/* A small deterministic generator (xorshift32): the runs are the same on every build. */
static uint32_t next_random(uint32_t *s)
{
    *s ^= *s << 13;
    *s ^= *s >> 17;
    *s ^= *s << 5;
    return *s;
}

static void flatten_supershader(sg_flat *f, sg_graph **g, char *err, size_t errlen)
{
    sg_params params;
    *g = load_supershader(&params);
    sg_params_free(&params);
    *f = (sg_flat){.err = err, .errlen = errlen};
    if (!sg_flatten(f, *g, NULL, 0, NULL, NULL))
        fail_msg("flatten: %s", err);
    assert_true(sg_flat_index_links(f));
    assert_true(f->t.n_links > 500); /* a graph big enough to mean something */
    assert_true(sg_flat_index_is_true(f));
}

/* Removals (walking one node's list as fold.c does, or at random) and redirections of one
 * output to another node's, interleaved until no link is left; the index checked after
 * every edit. */
static void test_edits_keep_the_index_true(void **state)
{
    (void)state;
    char err[SG_ERROR_MAX] = "";
    sg_flat f;
    sg_graph *g;
    flatten_supershader(&f, &g, err, sizeof err);
    uint32_t s = 12345;
    int edits = 0, walked = 0;
    while (f.t.n_links > 0) {
        uint32_t what = next_random(&s) % 3;
        sg_link k = f.t.links[next_random(&s) % (uint32_t)f.t.n_links];
        if (what == 0) {
            sg_flat_remove_link(&f, (int)(next_random(&s) % (uint32_t)f.t.n_links));
        } else if (what == 1) {
            int src = (int)(next_random(&s) % (uint32_t)f.t.n_nodes);
            int before = f.n_from[k.from_node] + (src == k.from_node ? 0 : f.n_from[src]);
            sg_flat_redirect_output(&f, k.from_node, k.from_socket, src, 0);
            assert_int_equal(f.n_from[k.from_node] + (src == k.from_node ? 0 : f.n_from[src]), before);
        } else {
            /* Remove every other link leaving k.from_node while walking its list; the walk
             * must see each of them exactly once. */
            int node = k.from_node, seen = 0, expected = f.n_from[node];
            bool drop = true;
            for (int l = f.first_from[node], next; l >= 0; l = next) {
                next = f.next_from[l];
                seen++;
                if (drop) {
                    int last = f.t.n_links - 1;
                    sg_flat_remove_link(&f, l);
                    if (next == last)
                        next = l;
                }
                drop = !drop;
            }
            assert_int_equal(seen, expected);
            walked++;
        }
        edits++;
        assert_true(sg_flat_index_is_true(&f));
    }
    assert_true(edits > 300 && walked > 50);
    sg_flat_free(&f);
    sg_graph_free(g);
}

/* The checker catches a list that skips a link, a wrong count and a stale input slot. */
static void test_a_corrupt_index_is_caught(void **state)
{
    (void)state;
    char err[SG_ERROR_MAX] = "";
    sg_flat f;
    sg_graph *g;
    flatten_supershader(&f, &g, err, sizeof err);
    int node = -1;
    for (int i = 0; i < f.t.n_nodes && node < 0; i++)
        if (f.n_from[i] >= 2)
            node = i;
    assert_true(node >= 0);

    int l = f.first_from[node], skipped = f.next_from[l];
    f.next_from[l] = f.next_from[skipped];
    assert_false(sg_flat_index_is_true(&f));
    f.next_from[l] = skipped;
    assert_true(sg_flat_index_is_true(&f));

    f.n_from[node]++;
    assert_false(sg_flat_index_is_true(&f));
    f.n_from[node]--;

    sg_link *k = &f.t.links[l];
    f.in_link[f.slot0[k->to_node] + k->to_socket] = -1;
    assert_false(sg_flat_index_is_true(&f));
    f.in_link[f.slot0[k->to_node] + k->to_socket] = l;
    assert_true(sg_flat_index_is_true(&f));
    sg_flat_free(&f);
    sg_graph_free(g);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_edits_keep_the_index_true),
        cmocka_unit_test(test_a_corrupt_index_is_caught),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
