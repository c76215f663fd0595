// A recorded log's text from a file, plain or xz-compressed (the standard SLAM logs ship as .clf.xz):
// the I/O in front of the pure log parsers (carmen.hpp). Compression is recognised by the xz magic
// bytes, not the file name.
#pragma once

#include <string>

#include "common/result.hpp"

namespace teamscan {

// The whole file's text; an xz stream is decompressed (liblzma). An unreadable file or a corrupt
// stream is an Error naming the problem.
[[nodiscard]] Result<std::string> read_log_text(const std::string& path);

}  // namespace teamscan
