#pragma once
// The error hierarchy. Library code throws these; they are caught in exactly two places: each tool's
// main (which maps the kind to a documented exit status) and each daemon job (which writes
// NAME.error.json). Messages name the thing and the fault, e.g.
//   "spec.json: pigments[1].size.r_eff_um: must be > 0 (got -0.2)".

#include <stdexcept>
#include <string>

namespace brdf {

enum class ErrorKind {
    Input,     ///< a spec, flag or value supplied by the user is invalid
    Format,    ///< a table or data file is malformed, truncated or unsupported
    Device,    ///< OpenCL platform, build or runtime failure
    Numerical, ///< a computation failed to converge or produced non-finite values
    Io,        ///< a file could not be read or written
    Limit,     ///< a request exceeds a resource limit (memory, time) without an override
    Internal,  ///< a bug: a broken invariant, or an exception that is not a brdf::Error
};

/// Exit statuses of brdftool and brdfd, documented in the README ("Exit status").
int exit_status(ErrorKind kind);
const char* to_string(ErrorKind kind);

class Error : public std::runtime_error {
public:
    Error(ErrorKind kind, const std::string& message) : std::runtime_error(message), m_kind(kind) {}
    ErrorKind kind() const { return m_kind; }

private:
    ErrorKind m_kind;
};

struct InputError : Error {
    explicit InputError(const std::string& message) : Error(ErrorKind::Input, message) {}
};
struct FormatError : Error {
    explicit FormatError(const std::string& message) : Error(ErrorKind::Format, message) {}
};
struct DeviceError : Error {
    explicit DeviceError(const std::string& message) : Error(ErrorKind::Device, message) {}
};
struct NumericalError : Error {
    explicit NumericalError(const std::string& message) : Error(ErrorKind::Numerical, message) {}
};
struct IoError : Error {
    explicit IoError(const std::string& message) : Error(ErrorKind::Io, message) {}
};
struct LimitError : Error {
    explicit LimitError(const std::string& message) : Error(ErrorKind::Limit, message) {}
};
/// Thrown where the code finds that it is wrong (an invariant broken), never for bad input: the
/// tools report it as "internal error" with exit status 70, a daemon job with kind "internal".
struct InternalError : Error {
    explicit InternalError(const std::string& message) : Error(ErrorKind::Internal, message) {}
};

} // namespace brdf
