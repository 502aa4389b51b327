/* libFuzzer target: TCPROS connection header parser. */
#include <stddef.h>
#include <stdint.h>
#include <string.h>
#include "tr_internal.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    tr_header h;
    char err[256], v[128];
    if (tr_header_parse(data, size, &h, err, sizeof err) == 0) {
        for (size_t i = 0; i < h.n; i++) {
            /* every field lies inside the input */
            if (h.f[i].key < (const char *)data || h.f[i].val + h.f[i].vlen > (const char *)data + size)
                __builtin_trap();
        }
        tr_header_get(&h, "md5sum", v, sizeof v);
        tr_header_get(&h, "error", v, sizeof v);
        tr_header_get(&h, "callerid", v, 1);
    }
    return 0;
}
