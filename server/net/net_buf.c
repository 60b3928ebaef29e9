/* net: refcounted byte buffers with lws headroom, shared by every client that sends them. */
#include <stdlib.h>

#include "net_internal.h"

net_buf *net_buf_new(size_t len)
{
    if (len > SIZE_MAX - sizeof(net_buf) - LWS_PRE) return NULL;
    net_buf *b = malloc(sizeof *b + LWS_PRE + len);
    if (!b) return NULL;
    atomic_init(&b->refs, 1);
    b->len = len;
    return b;
}

unsigned char *net_buf_data(net_buf *b) { return b->mem + LWS_PRE; }
size_t net_buf_len(const net_buf *b) { return b->len; }
void net_buf_ref(net_buf *b) { atomic_fetch_add_explicit(&b->refs, 1, memory_order_relaxed); }

void net_buf_unref(net_buf *b)
{
    if (b && atomic_fetch_sub_explicit(&b->refs, 1, memory_order_acq_rel) == 1) free(b);
}
