/* test_cli_opts.c — the command line's option tables (src/cli) carry what
 * --help prints: every option a help line that fits the help's column, and
 * a value name exactly when it takes a value; an option name means the same
 * in every table (the parser reads the first table that has it); and the
 * help of a command and the overview (the man page's source) print every
 * option of the command's table with its value name and every line of its
 * help. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include "cli/cli.h"

/* The help column starts at 23 of an 80-column line. */
#define HELP_WIDTH 57

static void test_every_option_has_help(void **state)
{
	size_t i;
	const cli_opt *o;

	(void)state;
	assert_true(cli_ncommands >= 9);
	for (i = 0; i < cli_ncommands; ++i)
		for (o = cli_commands[i]->opts; o->kind >= 0; ++o) {
			const char *h = o->help;
			if (!o->name) {
				assert_null(o->help);
				continue;
			}
			if (!h || !*h)
				fail_msg("%s: option %s has no help line", cli_commands[i]->name, o->name);
			if ((o->kind != CLI_FLAG) != (o->metavar && *o->metavar))
				fail_msg("%s: option %s: a value name exactly when it takes a value",
				         cli_commands[i]->name, o->name);
			while (*h) {
				size_t n = strcspn(h, "\n");
				if (n == 0 || n > HELP_WIDTH)
					fail_msg("%s: option %s: a help line of %zu characters",
					         cli_commands[i]->name, o->name, n);
				h += n + (h[n] == '\n');
			}
		}
}

static void test_same_name_same_option(void **state)
{
	size_t i, j;
	const cli_opt *o, *p;

	(void)state;
	for (i = 0; i < cli_ncommands; ++i)
		for (o = cli_commands[i]->opts; o->kind >= 0; ++o)
			for (j = 0; o->name && j <= i; ++j)
				for (p = cli_commands[j]->opts; p->kind >= 0 && p != o; ++p) {
					if (!p->name || strcmp(p->name, o->name) != 0)
						continue;
					if (j == i)
						fail_msg("%s: option %s twice in its table", cli_commands[i]->name,
						         o->name);
					if (p->kind != o->kind || p->common != o->common || p->parse != o->parse)
						fail_msg("option %s: %s and %s parse it differently", o->name,
						         cli_commands[j]->name, cli_commands[i]->name);
				}
}

/* What cli_usage prints, in a buffer the caller frees. */
static char *usage_of(const cli_command *cmd)
{
	char *buf = NULL;
	size_t len = 0;
	FILE *fp = open_memstream(&buf, &len);

	assert_non_null(fp);
	cli_usage(fp, cli_commands, cli_ncommands, cmd);
	assert_int_equal(fclose(fp), 0);
	return buf;
}

/* text holds "  -o OUT.csv" (or "  --keep") and then every help line of o. */
static void assert_listed(const char *text, const char *cmd, const cli_opt *o)
{
	char line[128];
	const char *h = o->help, *at;

	snprintf(line, sizeof line, "\n  %s%s%s%s", o->name[1] ? "--" : "-", o->name,
	         o->metavar ? " " : "", o->metavar ? o->metavar : "");
	if (!(at = strstr(text, line)))
		fail_msg("%s --help: no line '%s'", cmd, line + 1);
	while (*h) {
		size_t n = strcspn(h, "\n");
		snprintf(line, sizeof line, " %.*s\n", (int)n, h);
		if (!(at = strstr(at, line)))
			fail_msg("%s --help: option %s without its help line '%.*s' (in order)", cmd,
			         o->name, (int)n, h);
		h += n + (h[n] == '\n');
	}
}

/* The overview's part on cmd: from its usage to the blank line after it. */
static char *part_of(const char *all, const cli_command *cmd)
{
	const char *at = strstr(all, cmd->usage), *end;

	if (!at)
		fail_msg("--help: no usage of %s", cmd->name);
	end = strstr(at, "\n\n");
	return strndup(at - 1, end ? (size_t)(end - at + 2) : strlen(at) + 1);
}

static void test_help_prints_the_tables(void **state)
{
	char *all = usage_of(NULL);
	size_t i;
	const cli_opt *o;

	(void)state;
	for (i = 0; i < cli_ncommands; ++i) {
		char *one = usage_of(cli_commands[i]), *part = part_of(all, cli_commands[i]);
		for (o = cli_commands[i]->opts; o->kind >= 0; ++o)
			if (o->name) {
				assert_listed(one, cli_commands[i]->name, o);
				/* the common options: once, in Common options */
				assert_listed(o->common ? all : part, cli_commands[i]->name, o);
			}
		free(one);
		free(part);
	}
	free(all);
}

int main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_every_option_has_help),
		cmocka_unit_test(test_same_name_same_option),
		cmocka_unit_test(test_help_prints_the_tables),
	};

	return cmocka_run_group_tests(tests, NULL, NULL);
}
