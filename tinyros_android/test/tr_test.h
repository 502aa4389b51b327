/* Minimal assertion helpers for the tinyros C tests: each failed check prints
 * file:line and the expression, and main returns non-zero. */
#ifndef TR_TEST_H
#define TR_TEST_H
#include <stdio.h>
#include <string.h>

static int tr_failures = 0;
static int tr_checks = 0;

#define CHECK(cond) do { tr_checks++; if (!(cond)) { tr_failures++; \
    fprintf(stderr, "%s:%d: CHECK failed: %s\n", __FILE__, __LINE__, #cond); } } while (0)
#define CHECK_EQ_INT(a, b) do { long long _a = (long long)(a), _b = (long long)(b); tr_checks++; \
    if (_a != _b) { tr_failures++; fprintf(stderr, "%s:%d: %s == %lld, expected %s == %lld\n", \
    __FILE__, __LINE__, #a, _a, #b, _b); } } while (0)
#define CHECK_STR(a, b) do { const char *_a = (a), *_b = (b); tr_checks++; \
    if (!_a || strcmp(_a, _b)) { tr_failures++; fprintf(stderr, "%s:%d: %s is \"%s\", expected \"%s\"\n", \
    __FILE__, __LINE__, #a, _a ? _a : "(null)", _b); } } while (0)
#define CHECK_CONTAINS(hay, needle) do { const char *_h = (hay); tr_checks++; \
    if (!_h || !strstr(_h, needle)) { tr_failures++; fprintf(stderr, "%s:%d: \"%s\" does not contain \"%s\"\n", \
    __FILE__, __LINE__, _h ? _h : "(null)", needle); } } while (0)
#define TEST_DONE() do { printf("%d checks, %d failures\n", tr_checks, tr_failures); \
    return tr_failures ? 1 : 0; } while (0)
#endif
