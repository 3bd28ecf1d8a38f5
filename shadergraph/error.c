#include <stdarg.h>
#include <stdio.h>

#include "shadergraph/shadergraph.h"

int sg_error_set(char *err, size_t errlen, const char *fmt, ...)
{
    if (err && errlen) {
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(err, errlen, fmt, ap);
        va_end(ap);
    }
    return -1;
}

int sg_socket_type_width(sg_socket_type t)
{
    switch (t) {
    case SG_SOCKET_VECTOR:
    case SG_SOCKET_COLOR:
        return 3;
    case SG_SOCKET_SHADER:
        return 0;
    default:
        return 1;
    }
}

const char *sg_socket_type_name(sg_socket_type t)
{
    switch (t) {
    case SG_SOCKET_FLOAT: return "FLOAT";
    case SG_SOCKET_VECTOR: return "VECTOR";
    case SG_SOCKET_COLOR: return "RGBA";
    case SG_SOCKET_SHADER: return "SHADER";
    case SG_SOCKET_INT: return "INT";
    case SG_SOCKET_BOOL: return "BOOLEAN";
    }
    return "?";
}
