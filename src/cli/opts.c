/* opts.c — the command line's option parser and help, both driven by the
 * commands' option tables (cli.h): getopt_long over every option any table
 * names, then each option checked against the table of the command it was
 * given to and stored where that table says. */
#include <errno.h>
#include <getopt.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "poolreps/exp.h"
#include "poolreps/internal.h"
#include "cli.h"

/* Options of no command's table: they act at once (help, help-keys,
 * version) or apply to every command (-q). getopt returns a one-letter
 * one's letter (its alias too), any other G_BASE + its id. */
enum { G_QUIET = 1, G_HELP, G_HELP_KEYS, G_VERSION };
static const struct {
	const char *name, *alias; /* alias: the long name of a one-letter option */
	int id;
	const char *help;
} globals[] = {
	{"q", NULL, G_QUIET, "quiet: no progress, no summary line"},
	{"h", "help", G_HELP, "this help; after a COMMAND, that command's usage"},
	{"help-keys", NULL, G_HELP_KEYS, "every parameter key with default, unit and range"},
	{"version", NULL, G_VERSION, "print the version and exit"},
};
#define NGLOBALS (sizeof globals / sizeof globals[0])

/* The options main reads itself, as every table that has them declares them. */
static const cli_opt common_opts[] = {
	CLI_COMMON_C, CLI_COMMON_SET, CLI_COMMON_SEED, CLI_COMMON_PROGRESS, CLI_END
};

/* Every option name of every table, once (the first table's definition). */
#define MAX_OPTS 64
typedef struct {
	const cli_opt *opt[MAX_OPTS];
	int n;
	struct option longopts[MAX_OPTS + 2 * NGLOBALS + 1];
	char shortopts[2 * MAX_OPTS + NGLOBALS + 2];
} option_set;
#define G_BASE (256 + MAX_OPTS)

static const cli_opt *find_opt(const cli_opt *opts, const char *name)
{
	for (; opts->kind >= 0; ++opts)
		if (opts->name && strcmp(opts->name, name) == 0)
			return opts;
	return NULL;
}

static int takes_value(const cli_opt *o)
{
	return o->kind != CLI_FLAG;
}

/* getopt's tables: a long option's val is 256 + its index, a letter its own. */
static void build_options(option_set *s, const cli_command *const *cmds, size_t ncmds)
{
	const cli_opt *o;
	size_t i, j;
	int nl = 0, ns = 0;

	s->n = 0;
	s->shortopts[ns++] = ':';
	for (j = 0; j < NGLOBALS; ++j) {
		const char *name = globals[j].name;
		int val = name[1] ? G_BASE + globals[j].id : name[0];
		if (!name[1])
			s->shortopts[ns++] = name[0];
		if (name[1] || globals[j].alias) {
			struct option lo = {name[1] ? name : globals[j].alias, no_argument, 0, val};
			s->longopts[nl++] = lo;
		}
	}
	for (i = 0; i < ncmds; ++i)
		for (o = cmds[i]->opts; o->kind >= 0; ++o) {
			int k;
			if (!o->name)
				continue;
			for (k = 0; k < s->n && strcmp(s->opt[k]->name, o->name) != 0; ++k)
				;
			if (k < s->n || s->n == MAX_OPTS)
				continue;
			s->opt[s->n] = o;
			if (o->name[1]) {
				struct option lo = {o->name, takes_value(o) ? required_argument : no_argument, 0,
				                    256 + s->n};
				s->longopts[nl++] = lo;
			} else {
				s->shortopts[ns++] = o->name[0];
				if (takes_value(o))
					s->shortopts[ns++] = ':';
			}
			s->n++;
		}
	s->shortopts[ns] = '\0';
	memset(&s->longopts[nl], 0, sizeof s->longopts[nl]);
}

/* The definition behind getopt's answer c, or NULL. */
static const cli_opt *opt_of(const option_set *s, int c)
{
	int k;

	if (c >= 256 && c < 256 + s->n)
		return s->opt[c - 256];
	for (k = 0; c < 256 && k < s->n; ++k)
		if (!s->opt[k]->name[1] && s->opt[k]->name[0] == c)
			return s->opt[k];
	return NULL;
}

static const char *dashes(const char *name)
{
	return name[1] ? "--" : "-";
}

/* After --help-keys or --version: report a failed write to stdout. */
int cli_stdout_done(void)
{
	errno = 0;
	if (fflush(stdout) == 0 && !ferror(stdout))
		return 0;
	fprintf(stderr, "poolreps: <stdout>: write error: %s\n", strerror(errno ? errno : EIO));
	return 2;
}

/* The value of a common option into c. */
static void set_common(cli_common *c, const cli_opt *o, char *value)
{
	switch (o->common) {
	case CLI_AT_CONFIG: c->config = value; break;
	case CLI_AT_SET: c->sets[c->nsets++] = value; break;
	case CLI_AT_SEED: c->seed = value; c->seed_at = c->nsets; break;
	case CLI_AT_PROGRESS: c->progress = 1; break;
	}
}

/* One option getopt returned: its value checked, recorded in g. */
static int take_option(const option_set *s, int c, char **argv, cli_given *g, cli_common *cm,
                       char *msg)
{
	const cli_opt *o = opt_of(s, c);
	int k;

	if (c == ':') {
		snprintf(msg, CLI_MSGLEN, "option %s needs a value (see poolreps --help)", argv[optind - 1]);
		return 1;
	}
	if (!o) {
		/* in a group such as -qZ, optind may not have moved past it yet */
		if (optopt)
			snprintf(msg, CLI_MSGLEN, "unknown option -%c (see poolreps --help)", optopt);
		else
			snprintf(msg, CLI_MSGLEN, "unknown option %s (see poolreps --help)", argv[optind - 1]);
		return 1;
	}
	if (o->kind == CLI_NUMBER) {
		union { double d; long l; } scratch;
		const char *must = o->parse(optarg, &scratch);
		if (must) {
			snprintf(msg, CLI_MSGLEN, "--%s %.40s: must be %s", o->name, optarg, must);
			return 1;
		}
	}
	/* a value given twice would silently drop the first (lists repeat by design) */
	for (k = 0; o->kind != CLI_LIST && k < g->n; ++k)
		if (g->opt[k] == o) {
			snprintf(msg, CLI_MSGLEN, "option %s%s given twice%s", dashes(o->name), o->name,
			         o->common == CLI_AT_CONFIG ?
			         ": give one parameter file (--set overrides single keys)" : "");
			return 1;
		}
	g->opt[g->n] = o;
	g->value[g->n++] = takes_value(o) ? optarg : NULL;
	if (o->common)
		set_common(cm, o, optarg);
	return 0;
}

int cli_parse(int argc, char **argv, const cli_command *const *cmds, size_t ncmds,
              cli_given *g, cli_common *c, int *help, int *optind_out, int *code, char *msg)
{
	option_set s;
	int ch;

	build_options(&s, cmds, ncmds);
	memset(g, 0, sizeof *g);
	memset(c, 0, sizeof *c);
	g->opt = calloc((size_t)argc + 1, sizeof *g->opt);
	g->value = calloc(3 * ((size_t)argc + 1), sizeof *g->value);
	if (!g->opt || !g->value) {
		snprintf(msg, CLI_MSGLEN, "out of memory");
		*code = pr_exit_code(PR_ENOMEM);
		return -1;
	}
	c->sets = g->value + argc + 1;
	g->spare = c->sets + argc + 1;
	opterr = 0;
	while ((ch = getopt_long(argc, argv, s.shortopts, s.longopts, NULL)) != -1) {
		if (ch == 'h') {
			*help = 1;
		} else if (ch == 'q') {
			c->quiet = 1;
		} else if (ch == G_BASE + G_HELP_KEYS || ch == G_BASE + G_VERSION) {
			if (ch == G_BASE + G_VERSION)
				printf("poolreps %s\n", pr_version());
			else
				pr_config_help(pr_exp_config, NULL, stdout);
			*code = cli_stdout_done();
			return -1;
		} else if (take_option(&s, ch, argv, g, c, msg)) {
			return 1;
		}
	}
	*optind_out = optind;
	return 0;
}

void cli_given_free(cli_given *g)
{
	free(g->opt);
	free(g->value);
}

int cli_has(const cli_given *g, const char *name)
{
	int k;

	for (k = 0; k < g->n; ++k)
		if (strcmp(g->opt[k]->name, name) == 0)
			return 1;
	return 0;
}

static void *field(void *opts, size_t at)
{
	return (char *)opts + at;
}

int cli_apply(const cli_command *cmd, const cli_given *g, void *opts, char *msg)
{
	size_t used = 0;
	int k, j;

	for (k = 0; k < g->n; ++k) {
		const cli_opt *o = find_opt(cmd->opts, g->opt[k]->name);
		if (!o) {
			snprintf(msg, CLI_MSGLEN, "%s: option %s%s does not apply (see poolreps %s --help)",
			         cmd->name, dashes(g->opt[k]->name), g->opt[k]->name, cmd->name);
			return 1;
		}
		if (o->common)
			continue;
		switch (o->kind) {
		case CLI_STR: *(const char **)field(opts, o->at) = g->value[k]; break;
		case CLI_FLAG: *(int *)field(opts, o->at) = 1; break;
		case CLI_NUMBER:
			o->parse(g->value[k], field(opts, o->at));
			*(int *)field(opts, o->count_at) = 1;
			break;
		case CLI_LIST: {
			int *n = field(opts, o->count_at);
			if (*n == 0) {
				*(char ***)field(opts, o->at) = g->spare + used;
				for (j = k; j < g->n; ++j)
					used += g->opt[j] == g->opt[k];
			}
			(*(char ***)field(opts, o->at))[(*n)++] = g->value[k];
			break;
		}
		}
	}
	return 0;
}

void cli_arg_key(const char *arg, char *key, size_t size)
{
	const char *p = arg + strspn(arg, " \t");
	size_t n = strcspn(p, "=");

	while (n && (p[n - 1] == ' ' || p[n - 1] == '\t'))
		--n;
	snprintf(key, size, "%.*s", (int)n, p);
}

int cli_check(const cli_command *cmd, const cli_common *c, const void *opts, char *msg)
{
	int i;

	/* a key the command never reads would be ignored: refuse it */
	for (i = 0; cmd->keys && i < c->nsets; ++i) {
		char key[64];
		cli_arg_key(c->sets[i], key, sizeof key);
		if (!pr_config_key_listed(cmd->keys, key)) {
			snprintf(msg, CLI_MSGLEN, "%s: --set %s does not apply (see poolreps %s --help)",
			         cmd->name, key, cmd->name);
			return 1;
		}
	}
	if (cmd->keys && c->seed && !pr_config_key_listed(cmd->keys, "experiment.seed")) {
		snprintf(msg, CLI_MSGLEN, "%s: option --seed does not apply (see poolreps %s --help)",
		         cmd->name, cmd->name);
		return 1;
	}
	/* -q silences the progress --progress asks for */
	if (c->progress && c->quiet) {
		snprintf(msg, CLI_MSGLEN, "%s: -q and --progress contradict: give one", cmd->name);
		return 1;
	}
	return cmd->check ? cmd->check(opts, c, msg) : 0;
}

void cli_hand(const cli_command *cmd, void *opts, int nops, char **ops, const pr_progress *prog,
              const pr_provenance *prov, char *note, int quiet)
{
	const cli_opt *o;

	for (o = cmd->opts; o->kind >= 0; ++o)
		switch (o->kind) {
		case CLI_OPERANDS:
			*(char ***)field(opts, o->at) = ops;
			*(int *)field(opts, o->count_at) = nops;
			break;
		case CLI_PROGRESS: *(pr_progress *)field(opts, o->at) = *prog; break;
		case CLI_PROV: *(pr_provenance *)field(opts, o->at) = *prov; break;
		case CLI_NOTE: *(char **)field(opts, o->at) = note; break;
		case CLI_QUIET: *(int *)field(opts, o->at) = quiet; break;
		}
}

/* "  -o OUT.csv           what it is", its continuation lines under the
 * help; a longer option and value put the help on the next line. */
static void print_line(FILE *fp, const char *name, const char *alias, const char *metavar,
                       const char *help)
{
	char left[64];
	size_t n = strcspn(help, "\n");

	snprintf(left, sizeof left, "%s%s%s%s%s%s", dashes(name), name, alias ? ", --" : "",
	         alias ? alias : "", metavar ? " " : "", metavar ? metavar : "");
	fprintf(fp, strlen(left) > 20 ? "  %s\n%23s%.*s\n" : "  %-20s %s%.*s\n", left, "", (int)n,
	        help);
	for (help += n; *help; help += n) {
		n = strcspn(++help, "\n");
		fprintf(fp, "%23s%.*s\n", "", (int)n, help);
	}
}

/* The lines of a table's options (common: those main reads, else the others). */
static void print_options(FILE *fp, const cli_opt *opts, int common)
{
	for (; opts->kind >= 0; ++opts)
		if (opts->name && !opts->common == !common)
			print_line(fp, opts->name, NULL, opts->metavar, opts->help);
}

/* "  Accepts: -c, -o, --set, -q, -h." from a command's table. */
static void print_accepts(FILE *fp, const cli_command *cmd)
{
	const cli_opt *o;

	fprintf(fp, "  Accepts:");
	for (o = cmd->opts; o->kind >= 0; ++o)
		if (o->name)
			fprintf(fp, " %s%s,", dashes(o->name), o->name);
	fprintf(fp, " -q, -h.\n");
}

/* The keys a command's --set may change: listed with their defaults, or
 * (run, config, sweep: every key) a pointer to --help-keys. */
static void print_keys(FILE *fp, const cli_command *cmd)
{
	if (!find_opt(cmd->opts, "set"))
		return;
	if (!cmd->keys) {
		fprintf(fp, "  --set keys: every parameter key (poolreps --help-keys).\n");
		return;
	}
	fprintf(fp, "\n");
	pr_config_help(pr_exp_config, cmd->keys, fp);
}

static void print_common(FILE *fp)
{
	size_t i;

	fprintf(fp, "\nCommon options (a command takes those its Accepts line lists, each at\n"
	            "most once except --set; any other is refused):\n");
	print_options(fp, common_opts, 1);
	for (i = 0; i < NGLOBALS; ++i)
		print_line(fp, globals[i].name, globals[i].alias, NULL, globals[i].help);
	fprintf(fp, "\nExit codes: 0 ok, 1 bad usage or parameter, 2 I/O or malformed CSV,\n"
	            "  3 numerical failure, 4 out of memory, 128 + N stopped by signal N\n"
	            "  (130 SIGINT, 143 SIGTERM, 129 SIGHUP, 131 SIGQUIT, 141 SIGPIPE, 153 SIGXFSZ).\n");
}

void cli_experiments(FILE *fp)
{
	const pr_experiment *e;
	int i;

	fprintf(fp, "name,folder,kind,summary,title\n");
	for (i = 0; (e = pr_exp_at(i)); ++i)
		fprintf(fp, "%s,%s,%s,%s,%s\n", e->name, e->folder, e->kind, e->summary ? e->summary : "",
		        e->title);
}

void cli_usage(FILE *fp, const cli_command *const *cmds, size_t ncmds, const cli_command *cmd)
{
	size_t i;

	if (cmd) {
		fprintf(fp, "Usage: %s\n", cmd->usage);
		print_options(fp, cmd->opts, 0);
		print_accepts(fp, cmd);
		print_keys(fp, cmd);
	} else {
		fprintf(fp, "Usage: poolreps CONFIG | poolreps COMMAND [options] | poolreps help [COMMAND]\n"
		            "\nCommands:\n");
		for (i = 0; i < ncmds; ++i) {
			fprintf(fp, "%s  %s\n", i ? "\n" : "", cmds[i]->usage);
			print_options(fp, cmds[i]->opts, 0);
			print_accepts(fp, cmds[i]);
		}
	}
	print_common(fp);
	if (!cmd)
		fprintf(fp, "\nParameter keys: poolreps --help-keys lists them all (also docs/parameters.md\n"
		            "and the man page). Experiments: poolreps help experiments lists them\n"
		            "(CSV: name, folder, kind, summary, title).\n");
}
