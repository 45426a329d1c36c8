/* Helpers for the raddiff.hpp tests (C++17): CHECK_THROWS runs an expression that must throw
   raddiff::Error with the given status and a message containing the given text. */
#ifndef RADDIFF_FFI_HPP_CHECK_H
#define RADDIFF_FFI_HPP_CHECK_H
#include "raddiff.hpp"
#include "check.h"
#include <cstring>
#include <string>

#define CHECK_THROWS(expr, expected_status, text)                                                   \
  do {                                                                                              \
    bool thrown_ = false;                                                                           \
    try {                                                                                           \
      (void)(expr);                                                                                 \
    } catch (const raddiff::Error &e_) {                                                            \
      thrown_ = true;                                                                               \
      if (e_.status() != (expected_status)) {                                                       \
        fprintf(stderr, "%s:%d: %s threw status %d, expected %d (%s)\n", __FILE__, __LINE__, #expr, \
                (int)e_.status(), (int)(expected_status), e_.what());                               \
        check_failures++;                                                                           \
      }                                                                                             \
      if (std::strstr(e_.what(), (text)) == nullptr) {                                              \
        fprintf(stderr, "%s:%d: %s: message \"%s\" lacks \"%s\"\n", __FILE__, __LINE__, #expr,      \
                e_.what(), (text));                                                                 \
        check_failures++;                                                                           \
      }                                                                                             \
    }                                                                                               \
    if (!thrown_) {                                                                                 \
      fprintf(stderr, "%s:%d: %s did not throw raddiff::Error\n", __FILE__, __LINE__, #expr);      \
      check_failures++;                                                                             \
    }                                                                                               \
  } while (0)

#endif
