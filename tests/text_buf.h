/* text_buf.h — a growable byte buffer for the C tests, NUL-terminated after
 * every append (the bytes may hold NULs of their own). Include after
 * cmocka.h. */
#ifndef POOLREPS_TEST_TEXT_BUF_H
#define POOLREPS_TEST_TEXT_BUF_H

#include <stdlib.h>
#include <string.h>

typedef struct {
	char *buf;
	size_t len, cap;
} text_buf;

static inline void text_append(text_buf *g, const char *s, size_t n)
{
	if (g->len + n + 1 > g->cap) {
		g->cap = 2 * (g->len + n + 1);
		g->buf = realloc(g->buf, g->cap);
		assert_non_null(g->buf);
	}
	memcpy(g->buf + g->len, s, n);
	g->len += n;
	g->buf[g->len] = '\0';
}

static inline void text_puts(text_buf *g, const char *s)
{
	text_append(g, s, strlen(s));
}

#endif
