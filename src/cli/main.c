/* main.c — the poolreps command line: a dispatch over the commands' tables
 * (cli.h). Parse the options, pick the command, build the configuration,
 * call the command, print its one-line error, map status to exit. */
#include <errno.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <time.h>
#include <unistd.h>

#include <gsl/gsl_errno.h>

#include "poolreps/config.h"
#include "poolreps/exp.h"
#include "poolreps/internal.h"
#include "cli.h"

/* During a run or merge, the first signal asks the loops to stop (they
 * return PR_EINTR and remove the staging folder). Otherwise, or on a second
 * signal, remove every registered temporary file and staging folder and
 * leave at once with 128 + the signal. Only async-signal-safe calls. */
static volatile sig_atomic_t graceful;

static void say_now(const char *s)
{
	ssize_t rc = write(STDERR_FILENO, s, strlen(s));
	(void)rc;
}

static const char *signal_name(int sig)
{
	static const struct { int sig; const char *name; } names[] = {
		{SIGINT, "SIGINT"}, {SIGTERM, "SIGTERM"}, {SIGHUP, "SIGHUP"}, {SIGQUIT, "SIGQUIT"},
		{SIGPIPE, "SIGPIPE"}, {SIGXFSZ, "SIGXFSZ"}, {SIGXCPU, "SIGXCPU"}, {SIGUSR1, "SIGUSR1"},
		{SIGUSR2, "SIGUSR2"}, {SIGALRM, "SIGALRM"}, {SIGVTALRM, "SIGVTALRM"}};
	size_t i;

	for (i = 0; i < sizeof names / sizeof names[0]; ++i)
		if (names[i].sig == sig)
			return names[i].name;
	return "a signal";
}

/* The grace the loops of a run, merge, sweep or collect get to stop after
 * the first signal: they check pr_interrupted between steps, but one step
 * (a large factorisation inside GSL) can take minutes, and a batch system
 * kills 30 s after SIGTERM. When it runs out, the handler cleans up and
 * exits itself: the signal is honoured within a second. */
#define STOP_GRACE_NS 400000000L
static timer_t stop_timer;
static volatile sig_atomic_t have_timer, deadline_armed;

static void arm_deadline(void)
{
	struct itimerspec its = {{0, 0}, {0, STOP_GRACE_NS}};

	if (have_timer && timer_settime(stop_timer, 0, &its, NULL) == 0)
		deadline_armed = 1;
}

/* The timer of the grace period, made before any signal can need it. */
static void make_stop_timer(void)
{
	struct sigevent sev;

	memset(&sev, 0, sizeof sev);
	sev.sigev_notify = SIGEV_SIGNAL;
	sev.sigev_signo = SIGALRM;
	have_timer = timer_create(CLOCK_MONOTONIC, &sev, &stop_timer) == 0;
}

static void on_signal(int sig)
{
	/* the grace of the first signal ran out: act on it now */
	if (sig == SIGALRM && deadline_armed && pr_interrupted) {
		sig = (int)pr_interrupted;
	} else if ((graceful || pr_committed) && !pr_interrupted) {
		/* the outputs are in place: the command ends as it is, successfully,
		 * rather than claiming that it left everything as it was */
		pr_interrupted = sig;
		if (!pr_committed)
			arm_deadline();
		return;
	}
	pr_cleanup_run();
	say_now("poolreps: interrupted by ");
	say_now(signal_name(sig));
	say_now(pr_committed ? ": the outputs were already complete and are kept\n"
	                     : ": partial output files removed, every existing file left as it was\n");
	_exit(pr_committed ? 0 : 128 + sig);
}

/* Progress on stderr: a bar with ETA on a terminal, else (--progress) a plain
 * line per 10 %. */
typedef struct {
	struct timespec t0;
	int tty, last_decile;
	int open; /* a bar is drawn and its line not ended */
	double last_draw;
} progress_state;

static void on_progress(void *user, long done, long total, const char *what)
{
	progress_state *p = user;
	struct timespec t;
	double el, frac = total > 0 ? (double)done / (double)total : 1.0, eta;
	int decile = (int)(frac * 10), i, fill = (int)(frac * 30);

	clock_gettime(CLOCK_MONOTONIC, &t);
	el = (double)(t.tv_sec - p->t0.tv_sec) + 1e-9 * (double)(t.tv_nsec - p->t0.tv_nsec);
	eta = frac > 0 ? el * (1 - frac) / frac : 0;
	if (p->tty) {
		if (el - p->last_draw < 0.1 && done < total)
			return;
		p->last_draw = el;
		fputc('\r', stderr);
		fputc('[', stderr);
		for (i = 0; i < 30; ++i)
			fputc(i < fill ? '#' : ' ', stderr);
		fprintf(stderr, "] %3.0f%% %s, %.0f s, ETA %.0f s  ", 100 * frac, what, el, eta);
		p->open = done < total;
		if (!p->open)
			fputc('\n', stderr);
	} else if (decile > p->last_decile) {
		p->last_decile = decile;
		fprintf(stderr, "poolreps: %s: %ld/%ld (%.0f%%), %.1f s elapsed, ETA %.0f s\n",
		        what, done, total, 100 * frac, el, eta);
	}
}

static void print_done(const struct timespec *t0, clock_t c0)
{
	struct rusage ru;
	struct timespec t1;

	getrusage(RUSAGE_SELF, &ru);
	clock_gettime(CLOCK_MONOTONIC, &t1);
	fprintf(stderr, "poolreps: done: wall %.2f s, cpu %.2f s, peak memory %.1f MiB\n",
	        (double)(t1.tv_sec - t0->tv_sec) + 1e-9 * (double)(t1.tv_nsec - t0->tv_nsec),
	        (double)(clock() - c0) / CLOCKS_PER_SEC, (double)ru.ru_maxrss / 1024.0);
}

/* The one error line: escaped like every library message (pr_err). */
static int fail(const char *msg)
{
	char line[PR_ERRLEN];

	pr_err(line, PR_EINVAL, "%s", msg);
	fprintf(stderr, "poolreps: %s\n", line);
	return 1;
}

static const cli_command *command_named(const char *name)
{
	size_t j;

	for (j = 0; j < cli_ncommands; ++j)
		if (strcmp(name, cli_commands[j]->name) == 0)
			return cli_commands[j];
	return NULL;
}

/* The command and its operands from the words after the options (*op: the
 * first); *cmd stays NULL only with --help. 0, or 1 with the message. */
static int pick_command(int argc, char **argv, int *op, int *help, const cli_given *g,
                        cli_common *c, const cli_command **cmd, int *nops, char ***ops, char *msg)
{
	int i = *op;

	/* poolreps help [COMMAND]: that command's --help; help experiments:
	 * the registry (*help = 2) */
	if (i < argc && strcmp(argv[i], "help") == 0) {
		*help = 1;
		if (i + 1 < argc && strcmp(argv[i + 1], "experiments") == 0) {
			if (i + 2 < argc)
				return snprintf(msg, CLI_MSGLEN, "help: unexpected argument '%.60s'",
				                argv[i + 2]) > 0;
			*help = 2;
			*op = argc;
			return 0;
		}
		if (++i < argc && !command_named(argv[i]))
			return snprintf(msg, CLI_MSGLEN, "help: unknown command '%.60s' (see poolreps --help)",
			                argv[i]) > 0;
		if (i < argc && i + 1 < argc)
			return snprintf(msg, CLI_MSGLEN, "help: unexpected argument '%.60s'", argv[i + 1]) > 0;
	}
	/* The first operand names a command; anything else is a parameter file. */
	if (i < argc && (*cmd = command_named(argv[i])))
		++i;
	else if (i < argc)
		*cmd = cli_commands[0];
	if (*help)
		return 0;
	if (!*cmd)
		return snprintf(msg, CLI_MSGLEN, "Usage: poolreps CONFIG | poolreps COMMAND [options] "
		                "(see poolreps --help)") > 0;
	if ((*cmd)->operands == CLI_OPS_CONFIG) {
		if (i < argc && c->config)
			return snprintf(msg, CLI_MSGLEN, "run: two parameter files (%s and -c %s): give one",
			                argv[i], c->config) > 0;
		if (i < argc)
			c->config = argv[i++];
		if (!c->config)
			return snprintf(msg, CLI_MSGLEN, "run: no parameter file given (poolreps CONFIG)") > 0;
	} else if ((*cmd)->operands == CLI_OPS_SWEEP && !cli_has(g, "missing") && i < argc) {
		c->config = argv[i++];
	} else if ((*cmd)->operands == CLI_OPS_ALL) {
		*nops = argc - i;
		*ops = argv + i;
		i = argc;
	}
	if (i < argc)
		return snprintf(msg, CLI_MSGLEN, "%s: unexpected argument '%.60s'", (*cmd)->name, argv[i]) > 0;
	*op = i;
	return 0;
}

/* Defaults, the parameter file, --set and --seed in the order given (the
 * last setting of a key wins), then one validation. A run
 * never reads another experiment's keys: a --set or --grid of one would
 * change nothing (a parameter file may hold them: one serves several). */
static int load_config(const cli_command *cmd, const cli_common *c, const cli_given *g,
                       pr_config *cfg, char *err)
{
	int rc = PR_OK, i;

	pr_config_init(cfg, pr_exp_config);
	if (c->config)
		rc = pr_config_load(cfg, c->config, err);
	for (i = 0; rc == PR_OK && i <= c->nsets; ++i) {
		if (c->seed && i == c->seed_at) {
			char buf[96];
			snprintf(buf, sizeof buf, "experiment.seed=%.60s", c->seed);
			if ((rc = pr_config_set(cfg, buf, err)))
				pr_err(err, rc, "--seed %.60s: must be an integer in 0..4294967295", c->seed);
		}
		if (rc == PR_OK && i < c->nsets)
			rc = pr_config_set(cfg, c->sets[i], err);
	}
	if (rc == PR_OK)
		rc = pr_config_validate(cfg, err);
	for (i = 0; rc == PR_OK && (cmd->flags & CLI_EXPERIMENT) && i < c->nsets + g->n; ++i) {
		char key[64];
		if (i >= c->nsets && strcmp(g->opt[i - c->nsets]->name, "grid") != 0)
			continue;
		cli_arg_key(i < c->nsets ? c->sets[i] : g->value[i - c->nsets], key, sizeof key);
		if (pr_config_key_elsewhere(cfg, key))
			rc = pr_err(err, PR_EINVAL, "%s: %s %s does not apply: experiment %s never reads it",
			            cmd->name, i < c->nsets ? "--set" : "--grid", key, cfg->run.name);
	}
	return rc;
}

/* The command's status as the exit code, with its one line (or the note). */
static int finish(const cli_command *cmd, int rc, char *err, const char *note, int quiet,
                  const struct timespec *t0, clock_t c0)
{
	char msg[PR_ERRLEN];

	if (rc != PR_OK) {
		/* an allocation failure anywhere below is the cause of the failure,
		 * whatever status the code above it turned it into */
		if (pr_out_of_memory && rc != PR_EINTR)
			rc = PR_ENOMEM;
		/* so is a signal that asked a run, merge, sweep or collect to stop
		 * (SIGPIPE: the write to the closed pipe fails next) */
		if (pr_interrupted && rc != PR_EINTR && rc != PR_ENOMEM) {
			snprintf(msg, sizeof msg, "%s", err);
			rc = pr_err(err, PR_EINTR, "interrupted by signal %d: %s", (int)pr_interrupted, msg);
		}
		fprintf(stderr, "poolreps: %s\n", err);
		return pr_exit_code(rc);
	}
	/* a signal after the commit point: the outputs are complete (exit 0) */
	if (pr_interrupted && pr_committed)
		fprintf(stderr, "poolreps: %s arrived after the outputs were complete: they are kept\n",
		        signal_name((int)pr_interrupted));
	else if (!quiet && note[0])
		fprintf(stderr, "poolreps: %s\n", note);
	if ((cmd->flags & CLI_DONE_LINE) && !quiet && !pr_interrupted)
		print_done(t0, c0);
	return 0;
}

/* Every fatal signal to on_signal; the others held while it runs. */
static void install_handlers(void)
{
	struct sigaction sa;
	int i;

	memset(&sa, 0, sizeof sa);
	sa.sa_handler = on_signal;
	sigemptyset(&sa.sa_mask);
	for (i = 0; pr_fatal_signals[i]; ++i)
		sigaddset(&sa.sa_mask, pr_fatal_signals[i]);
	for (i = 0; pr_fatal_signals[i]; ++i)
		sigaction(pr_fatal_signals[i], &sa, NULL);
}

/* Everything is cleaned up or in place: a late signal must not add a second
 * line to the one the command ends with. */
static void hold_signals(void)
{
	sigset_t set;
	int i;

	sigemptyset(&set);
	for (i = 0; pr_fatal_signals[i]; ++i)
		sigaddset(&set, pr_fatal_signals[i]);
	pthread_sigmask(SIG_BLOCK, &set, NULL);
}

/* Progress on stderr unless -q: plain lines only when asked (--progress),
 * so that a failure stays one stderr line. */
static pr_progress progress_for(const cli_common *c, progress_state *prog, const struct timespec *t0)
{
	pr_progress p = {NULL, NULL};

	memset(prog, 0, sizeof *prog);
	prog->tty = isatty(STDERR_FILENO);
	if (!c->quiet && (prog->tty || c->progress)) {
		prog->t0 = *t0;
		prog->last_decile = -1;
		p.fn = on_progress;
		p.user = prog;
	}
	return p;
}

/* Hand cmd what main owns, build the configuration, call the command:
 * its exit code. */
static int run_command(const cli_command *cmd, const cli_common *c, const cli_given *g, void *opts,
                       int nops, char **ops, const pr_provenance *prov, const struct timespec *t0,
                       clock_t c0)
{
	char err[PR_ERRLEN] = "", note[PR_ERRLEN] = "";
	progress_state prog;
	pr_progress progress;
	pr_config cfg;
	int rc;

	/* only now: a listing (--help, --help-keys, --version) writes no file,
	 * and a closed pipe ends it silently, as it ends any filter */
	install_handlers();
	if ((graceful = (cmd->flags & CLI_GRACEFUL) != 0))
		make_stop_timer();
	progress = progress_for(c, &prog, t0);
	cli_hand(cmd, opts, nops, ops, &progress, prov, note, c->quiet);
	if ((rc = load_config(cmd, c, g, &cfg, err)) == PR_OK)
		rc = cmd->fn(&cfg, opts, err);
	hold_signals();
	/* an error must not land at the end of an unfinished bar */
	if (!c->quiet && prog.open)
		fputs("\r\033[K", stderr);
	return finish(cmd, rc, err, note, c->quiet, t0, c0);
}

/* Parse, pick the command (or print help), check its options, run it. */
int main(int argc, char **argv)
{
	const cli_command *cmd = NULL;
	cli_given g;
	cli_common c;
	/* getopt_long permutes argv: provenance records the order as typed */
	pr_provenance prov = {argc, calloc((size_t)argc + 1, sizeof *argv), NULL};
	char msg[CLI_MSGLEN] = "", **ops = NULL;
	int help = 0, op = 0, nops = 0, code = 0, rc;
	void *opts = NULL;
	struct timespec t0;
	clock_t c0 = clock();

	clock_gettime(CLOCK_MONOTONIC, &t0);
	gsl_set_error_handler(pr_gsl_error_handler);
	if (!prov.argv) {
		fail("out of memory");
		return pr_exit_code(PR_ENOMEM);
	}
	memcpy(prov.argv, argv, (size_t)argc * sizeof *argv);
	rc = cli_parse(argc, argv, cli_commands, cli_ncommands, &g, &c, &help, &op, &code, msg);
	if (rc == 0)
		rc = pick_command(argc, argv, &op, &help, &g, &c, &cmd, &nops, &ops, msg);
	if (rc == 0 && help == 2) {
		cli_experiments(stdout);
		rc = -1;
		code = cli_stdout_done();
	} else if (rc == 0 && help) {
		cli_usage(stdout, cli_commands, cli_ncommands, cmd);
		rc = -1;
		code = cli_stdout_done();
	}
	if (rc == 0 && !(opts = calloc(1, cmd->size))) {
		rc = -1;
		code = pr_exit_code(PR_ENOMEM);
		snprintf(msg, sizeof msg, "out of memory");
	}
	if (rc == 0 && !(rc = cli_apply(cmd, &g, opts, msg)))
		rc = cli_check(cmd, &c, opts, msg);
	if (rc == 0) {
		code = run_command(cmd, &c, &g, opts, nops, ops, &prov, &t0, c0);
	} else if (msg[0]) {
		/* a usage error (exit 1), or memory ran out (code says 4) */
		fail(msg);
		code = rc > 0 ? 1 : code;
	}
	cli_given_free(&g);
	free(prov.argv);
	free(opts);
	return code;
}
