#include <brdf/core/error.h>

namespace brdf {

int exit_status(ErrorKind kind) {
    switch (kind) {
    case ErrorKind::Input: return 3;
    case ErrorKind::Format: return 4;
    case ErrorKind::Device: return 5;
    case ErrorKind::Numerical: return 6;
    case ErrorKind::Io: return 7;
    case ErrorKind::Limit: return 8;
    case ErrorKind::Internal: return 70;
    }
    return 70;
}

const char* to_string(ErrorKind kind) {
    switch (kind) {
    case ErrorKind::Input: return "input";
    case ErrorKind::Format: return "format";
    case ErrorKind::Device: return "device";
    case ErrorKind::Numerical: return "numerical";
    case ErrorKind::Io: return "io";
    case ErrorKind::Limit: return "limit";
    case ErrorKind::Internal: return "internal";
    }
    return "internal";
}

} // namespace brdf
