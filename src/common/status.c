#include "spherecull/sc_status.h"

const char *sc_strerror(sc_status status)
{
    switch (status) {
    case SC_OK:                   return "success";
    case SC_ERR_DEGENERATE:       return "degenerate geometry (duplicate or collinear vertices, zero area)";
    case SC_ERR_NONFINITE:        return "non-finite input (NaN or infinity)";
    case SC_ERR_RANGE:            return "result out of the representable range";
    case SC_ERR_INVALID_ARGUMENT: return "invalid argument";
    case SC_ERR_UNSUPPORTED:      return "not supported by this build or CPU";
    case SC_ERR_OUT_OF_MEMORY:    return "out of memory";
    case SC_ERR_IO:               return "input/output error";
    case SC_ERR_PARSE:            return "malformed input";
    case SC_ERR_LIMIT:            return "input exceeds a configured limit";
    case SC_ERR_CANCELLED:        return "cancelled";
    case SC_STATUS_COUNT:         break;
    }
    return "unknown status";
}
