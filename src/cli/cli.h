/* cli.h — the command line's own header (src/cli, linked into the poolreps
 * executable alone, against the poolreps/ headers: the public ones, the
 * library's private ones and the tool's).
 *
 * Each command declares its options in a table of cli_opt (name, kind,
 * where the value goes in that command's own struct, the value's name and
 * a help line) and is described by
 * one cli_command; main.c dispatches over them and opts.c parses, checks and
 * prints help from the same tables, so the help text (and the man page that
 * scripts/gen-man.sh makes from it) cannot drift from what is parsed.
 *
 * The table commands (forest, reps, policy) share the steps of cmd_util.c:
 * a table's row count, its columns by name or list, a matrix of selected
 * columns, a weight column. Messages name the file, the line and the
 * column. Several outputs of one command are committed together through
 * pr_outset (csvio.h). */
#ifndef POOLREPS_CLI_H
#define POOLREPS_CLI_H

#include <stddef.h>
#include <stdio.h>

#include "poolreps/internal.h"
#include "poolreps/csvio.h"
#include "poolreps/rundir.h"

/* The room of a usage message (an argument quoted in it may be long). */
#define CLI_MSGLEN (PR_ERRLEN + 64)

/* ---- option tables ---- */

enum cli_kind {
	CLI_STR,      /* an option with a value: const char * at */
	CLI_FLAG,     /* an option without one: int at, set to 1 */
	CLI_LIST,     /* a repeatable option with a value: char ** at (room for
	               * argc values), their count an int at count_at */
	CLI_NUMBER,   /* a value parse checks and stores at; an int at count_at
	               * set to 1 */
	/* not options: what main hands the command */
	CLI_OPERANDS, /* the operands after the command: char ** at, int count_at */
	CLI_PROGRESS, /* pr_progress at: progress reports unless -q */
	CLI_PROV,     /* pr_provenance at: the command line as typed */
	CLI_NOTE,     /* char * at: PR_ERRLEN bytes for a remark main prints
	               * after a success */
	CLI_QUIET     /* int at: -q given */
};

/* Options main reads itself (they shape the configuration or the output
 * to the terminal): their value goes into cli_common, not the command's
 * struct. */
enum cli_common_at { CLI_AT_CONFIG = 1, CLI_AT_SET, CLI_AT_SEED, CLI_AT_PROGRESS };

typedef struct {
	const char *name;  /* "o", "train" (one letter: -o, else --train); NULL: no option */
	int kind;
	int common;        /* a cli_common_at, or 0: at is in the command's struct */
	size_t at, count_at;
	/* CLI_NUMBER: 0 and the value at target, or nonzero and what the value
	 * must be ("a number > 0 and <= 1e6") */
	const char *(*parse)(const char *arg, void *target);
	/* --help's line: the value's name (NULL for a flag) and what the option
	 * does (a '\n' starts a continuation line) */
	const char *metavar, *help;
} cli_opt;

#define CLI_OPT(name, metavar, type, field, help) \
	{ name, CLI_STR, 0, offsetof(type, field), 0, NULL, metavar, help }
#define CLI_OPT_FLAG(name, type, field, help) \
	{ name, CLI_FLAG, 0, offsetof(type, field), 0, NULL, NULL, help }
#define CLI_OPT_LIST(name, metavar, type, field, count, help) \
	{ name, CLI_LIST, 0, offsetof(type, field), offsetof(type, count), NULL, metavar, help }
#define CLI_OPT_NUMBER(name, metavar, type, field, given, parse, help) \
	{ name, CLI_NUMBER, 0, offsetof(type, field), offsetof(type, given), parse, metavar, help }
#define CLI_GIVEN(kind, type, field) { NULL, kind, 0, offsetof(type, field), 0, NULL, NULL, NULL }
#define CLI_GIVEN_LIST(kind, type, field, count) \
	{ NULL, kind, 0, offsetof(type, field), offsetof(type, count), NULL, NULL, NULL }
/* -c FILE, --set SECTION.KEY=V, --seed N, --progress: the same line in every
 * table that has them and in the Common options of --help */
#define CLI_COMMON_C { "c", CLI_STR, CLI_AT_CONFIG, 0, 0, NULL, "FILE", "parameter file (INI)" }
#define CLI_COMMON_SET { "set", CLI_LIST, CLI_AT_SET, 0, 0, NULL, "SECTION.KEY=V", \
	"override one parameter (repeatable)" }
#define CLI_COMMON_SEED { "seed", CLI_STR, CLI_AT_SEED, 0, 0, NULL, "N", \
	"master seed (experiment.seed)" }
#define CLI_COMMON_PROGRESS { "progress", CLI_FLAG, CLI_AT_PROGRESS, 0, 0, NULL, NULL, \
	"run: progress lines on stderr when it is no terminal\n" \
	"(batch logs; a failure's line then follows them)" }

/* How a command takes its operands (the words after its name). */
enum cli_operands {
	CLI_OPS_NONE,    /* none */
	CLI_OPS_CONFIG,  /* run: the parameter file, or -c; one is required */
	CLI_OPS_SWEEP,   /* sweep: the parameter file, unless --missing */
	CLI_OPS_ALL      /* merge, collect: every operand (CLI_OPERANDS) */
};

enum {
	CLI_GRACEFUL = 1,    /* the first signal asks its loops to stop */
	CLI_EXPERIMENT = 2,  /* runs an experiment: a --set or --grid of another
	                      * experiment's key is refused */
	CLI_DONE_LINE = 4    /* ends with the wall, cpu and memory line (not with -q) */
};

typedef struct {
	const char *config, *seed;
	char **sets;
	int nsets, progress, quiet;
	int seed_at;       /* the --set count before the last --seed: options apply in order */
} cli_common;

typedef struct cli_command {
	const char *name;
	/* the synopsis and description --help prints (the options' lines
	 * come from opts) */
	const char *usage;
	/* every option it accepts besides -h, --version, -q, in the order --help
	 * lists them; ended by an entry of kind -1 */
	const cli_opt *opts;
	size_t size;  /* of its struct */
	/* the keys its --set may change ("sim." is section sim); NULL: every key */
	const char *keys;
	int operands, flags;
	/* NULL, or a check of the parsed options before the configuration is
	 * read: 0, or 1 with the message in msg (PR_ERRLEN bytes) */
	int (*check)(const void *opts, const cli_common *c, char *msg);
	int (*fn)(const pr_config *cfg, const void *opts, char *err);
} cli_command;

#define CLI_END { NULL, -1, 0, 0, 0, NULL, NULL, NULL }

extern const cli_command cli_run, cli_shoot, cli_forest, cli_reps, cli_policy, cli_config,
	cli_merge, cli_sweep, cli_collect, cli_learner;
/* All of them, in the order --help lists them; the first runs a parameter
 * file (commands.c). */
extern const cli_command *const cli_commands[];
extern const size_t cli_ncommands;

/* ---- the parser (opts.c) ---- */

/* The options as given, in order, before the command is known. */
typedef struct {
	int n;
	const cli_opt **opt;  /* its definition (the first table that has it) */
	char **value;         /* its value, NULL for a flag */
	char **spare;         /* room for the values of the command's lists */
} cli_given;

/* Parse argv (getopt_long over every table's options); cmds[ncmds].
 * 0, or -1 after --help-keys / --version (exit with *code), or 1 with the
 * message in msg. *optind_out: the first operand. */
int cli_parse(int argc, char **argv, const cli_command *const *cmds, size_t ncmds,
              cli_given *g, cli_common *c, int *help, int *optind_out, int *code, char *msg);
void cli_given_free(cli_given *g);
/* Check that every given option applies to cmd and store it in opts. */
int cli_apply(const cli_command *cmd, const cli_given *g, void *opts, char *msg);
/* The checks that need the command: --set keys and --seed it reads, -q
 * against --progress, the command's own check. */
int cli_check(const cli_command *cmd, const cli_common *c, const void *opts, char *msg);
/* The key of a "section.key=value" argument (--set, --grid), blanks trimmed. */
void cli_arg_key(const char *arg, char *key, size_t size);
/* Store what main hands cmd (operands, progress, provenance, note, -q). */
void cli_hand(const cli_command *cmd, void *opts, int nops, char **ops, const pr_progress *prog,
              const pr_provenance *prov, char *note, int quiet);
/* 1 if the option called name was given. */
int cli_has(const cli_given *g, const char *name);
/* After --help, --help-keys or --version: 0, or 2 and the line after a
 * failed write to stdout. */
int cli_stdout_done(void);
/* --help: cmd NULL for every command. */
void cli_usage(FILE *fp, const cli_command *const *cmds, size_t ncmds, const cli_command *cmd);
/* poolreps help experiments: the registry as CSV (name, folder, kind,
 * summary, title), the one list the pipeline scripts read. */
void cli_experiments(FILE *fp);

/* ---- shoot (the fuzz harness calls it too) ---- */

typedef struct {
	const char *input, *output, *trace;
	int keep;
} shoot_args;
int pr_cmd_shoot(const pr_config *cfg, const shoot_args *a, char *err);

/* ---- the table commands' shared steps (cmd_util.c) ---- */

/* Rows a table may hold: the library indexes samples with int. */
#define PR_CMD_MAX_ROWS 100000000L

/* PR_EIO unless t has 1 .. PR_CMD_MAX_ROWS data rows: "no data rows", or
 * the count over the limit. */
int pr_cmd_check_rows(const pr_csv *t, char *err);

/* The column called name, or PR_EIO "file:1: missing column 'name' (opt)". */
int pr_cmd_column(const pr_csv *t, const char *name, const char *opt, char *err);

/* The columns of list (pr_csv_select: "a,b" or a prefix "phi*") into a
 * new array *cols (caller frees); returns their count or a negative status. */
int pr_cmd_columns(const pr_csv *t, const char *list, int **cols, char *err);

/* A new n x k row-major matrix of columns cols of every row of t (n =
 * pr_csv_nrows(t), at least one row allocated); NULL and PR_ENOMEM. */
double *pr_cmd_matrix(const pr_csv *t, const int *cols, int k, char *err);

/* The weights of column col (1 for every row when col < 0) into a new
 * array *w: each >= 0 and not all zero; what names them in messages
 * ("weight", "base weight") and name is the column's option value. */
int pr_cmd_weights(const pr_csv *t, int col, const char *name, const char *what, double **w,
                   char *err);

/* PR_EINVAL if a column is in both lists a (na columns, named an in the
 * message, e.g. "a state") and b: "file: column 'x' is both a state and an action". */
int pr_cmd_disjoint(const pr_csv *t, const int *a, int na, const char *an, const int *b, int nb,
                    const char *bn, char *err);

/* The whole of file path into a new buffer *text of *len bytes (free()):
 * a regular file only (PR_EIO "not a regular file"), refused after its
 * first bytes unless it starts with magic (PR_EIO, "path" + not_it). */
int pr_cmd_read_whole(const char *path, const char *magic, const char *not_it, char **text,
                      size_t *len, char *err);

#endif
