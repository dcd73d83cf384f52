// Private: libmatio, opened when a .mat file is first read rather than linked into every
// command. Its HDF5 brings some thirty shared libraries (curl, Kerberos, LDAP, GnuTLS) that
// the dynamic loader would map at each start of a command that reads CSV (docs/performance.md,
// "Start-up"); the types and constants still come from <matio.h>.
#pragma once

#include <matio.h>

#include <string>

namespace blmd::internal {

// The libmatio functions mat.cc calls, resolved from the library.
struct MatioLibrary {
  decltype(&Mat_Open) Open = nullptr;
  decltype(&Mat_Close) Close = nullptr;
  decltype(&Mat_GetDir) GetDir = nullptr;
  decltype(&Mat_LogInitFunc) LogInitFunc = nullptr;
  decltype(&Mat_SizeOfClass) SizeOfClass = nullptr;
  decltype(&Mat_VarFree) VarFree = nullptr;
  decltype(&Mat_VarGetNumberOfFields) VarGetNumberOfFields = nullptr;
  decltype(&Mat_VarGetStructFieldByIndex) VarGetStructFieldByIndex = nullptr;
  decltype(&Mat_VarGetStructFieldnames) VarGetStructFieldnames = nullptr;
  decltype(&Mat_VarRead) VarRead = nullptr;
  decltype(&Mat_VarReadInfo) VarReadInfo = nullptr;
};

// The library, loaded once (thread-safe) by the name it was built against; an InputError
// naming `path` (the file that needed it) when it cannot be loaded or lacks a function.
const MatioLibrary& Matio(const std::string& path);

}  // namespace blmd::internal
