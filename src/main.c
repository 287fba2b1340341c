/* main.c — the poolreps command line: parse options, build the configuration,
 * call one library command, print its one-line error, map status to exit. */
#include <errno.h>
#include <getopt.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <time.h>
#include <unistd.h>

#include <gsl/gsl_errno.h>

#include "poolreps/cmd.h"
#include "poolreps/config.h"
#include "poolreps/exp.h"
#include "common_priv.h"

enum {
	O_SET = 256, O_SEED, O_VERSION, O_TRACE, O_TRAIN, O_TEST, O_TARGET, O_WEIGHT,
	O_LEAVES, O_RETURN, O_FEATURES, O_BASE, O_EPSILON, O_SUMMARY, O_STATE, O_ACTION,
	O_SAMPLE, O_GRID, O_SPLIT, O_MISSING, O_KEEP, O_HELP_KEYS, O_PROGRESS, O_OLD_MEAN,
	O_SAVE, O_LOAD
};

static const struct option longopts[] = {
	{"help", no_argument, 0, 'h'},
	{"help-keys", no_argument, 0, O_HELP_KEYS},
	{"version", no_argument, 0, O_VERSION},
	{"set", required_argument, 0, O_SET},
	{"seed", required_argument, 0, O_SEED},
	{"trace", required_argument, 0, O_TRACE},
	{"train", required_argument, 0, O_TRAIN},
	{"test", required_argument, 0, O_TEST},
	{"target", required_argument, 0, O_TARGET},
	{"weight", required_argument, 0, O_WEIGHT},
	{"leaves", required_argument, 0, O_LEAVES},
	{"return", required_argument, 0, O_RETURN},
	{"features", required_argument, 0, O_FEATURES},
	{"base", required_argument, 0, O_BASE},
	{"epsilon", required_argument, 0, O_EPSILON},
	{"summary", required_argument, 0, O_SUMMARY},
	{"state", required_argument, 0, O_STATE},
	{"action", required_argument, 0, O_ACTION},
	{"sample", required_argument, 0, O_SAMPLE},
	{"grid", required_argument, 0, O_GRID},
	{"split", required_argument, 0, O_SPLIT},
	{"missing", required_argument, 0, O_MISSING},
	{"keep", no_argument, 0, O_KEEP},
	{"progress", no_argument, 0, O_PROGRESS},
	{"old-mean", required_argument, 0, O_OLD_MEAN},
	{"save", required_argument, 0, O_SAVE},
	{"load", required_argument, 0, O_LOAD},
	{0, 0, 0, 0}
};

typedef struct {
	const char *name;
	const char *options; /* every option it accepts besides -h, --version, -q:
	                      * drives its --help line and the command-line check */
	int (*fn)(const pr_config *, const pr_cmd_args *, char *);
	const char *usage;
} command;

static const command commands[] = {
	{"run", "c,o,set,seed,progress", pr_cmd_run,
	 "poolreps [run] CONFIG [-o DIR] [--set section.key=value]... [--seed N] [-q]\n"
	 "  Run the experiment a parameter file describes; write CSVs, figures' data and\n"
	 "  provenance into DIR (default: results/<experiment.name>; figures: results/sim)."},
	{"shoot", "c,i,o,set,trace,keep", pr_cmd_shoot,
	 "poolreps shoot [-c FILE] [-i IN.csv] [-o OUT.csv] [--trace TRACE.csv] [--keep]\n"
	 "  One shot per input row. Input columns x0,y0,x1,y1,...,vx,vy. Output columns\n"
	 "  x0,y0,... (final), pocket0,... (id or -1), hit, min_gap, reward, t_end, events.\n"
	 "  --keep copies the input columns in front; the final positions are then\n"
	 "  final_x0,final_y0,..."},
	{"forest", "c,o,set,seed,train,test,target,weight,leaves,save,load", pr_cmd_forest,
	 "poolreps forest --train FILE --test FILE --target COLS [--weight COL] [--leaves FILE]\n"
	 "                [--save FOREST] [-o OUT.csv] [-c FILE] [--set forest.key=value]...\n"
	 "poolreps forest --load FOREST --test FILE [--leaves FILE] [-o OUT.csv]\n"
	 "  --save writes the fitted forest (text, format version 1, docs/forest.md);\n"
	 "  --load predicts with a saved one instead of fitting.\n"
	 "  Fit extra trees on the training CSV (inputs = every other column), predict the\n"
	 "  test CSV: one pred_<name> column per target. --leaves writes each test row's\n"
	 "  active leaf per tree. Timings and test MSE go to stderr (not with -q)."},
	{"reps", "c,i,o,set,return,features,base,epsilon,summary", pr_cmd_reps,
	 "poolreps reps --return COL --features LIST [--base COL] [--epsilon E]\n"
	 "              [--summary FILE] [-i IN.csv] [-o OUT.csv]\n"
	 "  REPS weights p for every input row; LIST is a comma list of columns or a\n"
	 "  prefix ending in '*'. --summary writes one row eta,dual,kl,ess,bound,residual,\n"
	 "  iterations,kl_gap,residual_rel,status,rank,cond,path: the certificate; status is\n"
	 "  active (|KL - epsilon| and the relative feature residual <= 1e-9), unreachable\n"
	 "  (eta = 0: p is the eta -> 0 limit, KL < epsilon) or failed, which exits 3; rank,\n"
	 "  cond and path say what the solver did (feature directions used, condition\n"
	 "  estimate of its last Hessian, steps taken)."},
	{"policy", "c,i,o,set,seed,train,state,action,weight,sample,target,old-mean", pr_cmd_policy,
	 "poolreps policy --train FILE --state COLS --action COLS --weight COL [--sample N]\n"
	 "                [--target COLS] [--old-mean COLS] [-i STATES.csv] [-o OUT.csv]\n"
	 "                [--set policy.key=value]...\n"
	 "  Fit the tree-LWR Gaussian policy; write mean and covariance (and N samples)\n"
	 "  for every state row of the input. policy.target = reward_state needs --target\n"
	 "  (the training rows' final reward-ball positions); policy.cov_center = old\n"
	 "  needs --old-mean (the means of the policies that drew the training rows)."},
	{"config", "c,o,set,seed", pr_cmd_config,
	 "poolreps config [-c FILE] [--set section.key=value]... [--seed N] [-o FILE]\n"
	 "  Write the effective configuration (defaults, file, overrides) as INI."},
	{"merge", "o", pr_cmd_merge,
	 "poolreps merge -o DIR RUN_DIR...\n"
	 "  Combine single-repetition or single-variant outputs into what one process\n"
	 "  would have written."},
	{"sweep", "o,set,seed,grid,split,missing", pr_cmd_sweep,
	 "poolreps sweep CONFIG [--grid SECTION.KEY=V1,V2,...]... [--split repetition|variant|both]\n"
	 "               -o SWEEP_DIR      |      poolreps sweep --missing SWEEP_DIR\n"
	 "  Write jobs over every combination of the grid values: one `poolreps run` per\n"
	 "  grid point and repetition and/or variant (exp1: setting, exp3: policy, exp4:\n"
	 "  policy, start and covariance), listed in SWEEP_DIR/jobs.txt and manifest.csv,\n"
	 "  with slurm.sbatch and parallel.sh to run them and point-N/config.ini per grid\n"
	 "  point. --missing prints the jobs that have not finished, to run again."},
	{"collect", "", pr_cmd_collect,
	 "poolreps collect SWEEP_DIR\n"
	 "  Merge every grid point's jobs into point-N/merged (as `merge` does) and write\n"
	 "  SWEEP_DIR/sweep_summary.csv: the grid values and the experiment's summary rows.\n"
	 "  Names the jobs not done if there are any."},
};
#define NCOMMANDS (sizeof commands / sizeof commands[0])

/* The keys a component command reads, so its --set may change ("sim." is
 * section sim); NULL: every key (run, config). */
static const char *command_keys(const command *cmd)
{
	static const struct {
		const char *name, *keys;
	} reads[] = {
		{"shoot", "table.,sim.,reward."},
		{"forest", "forest.,experiment.seed"},
		{"reps", "reps."},
		{"policy", "policy.,experiment.seed"},
		{"merge", ""},
		{"collect", ""},
	};
	size_t i;

	for (i = 0; i < sizeof reads / sizeof reads[0]; ++i)
		if (strcmp(reads[i].name, cmd->name) == 0)
			return reads[i].keys;
	return NULL;
}

/* The key of a "section.key=value" argument (--set, --grid), blanks trimmed. */
static void arg_key(const char *arg, char *key, size_t size)
{
	const char *p = arg + strspn(arg, " \t");
	size_t n = strcspn(p, "=");

	while (n && (p[n - 1] == ' ' || p[n - 1] == '\t'))
		--n;
	snprintf(key, size, "%.*s", (int)n, p);
}

/* "Accepts: -c, -o, --set" from a command's option list. */
static void print_options(FILE *fp, const char *options)
{
	const char *p = options;

	fprintf(fp, "  Accepts:");
	while (*p) {
		size_t n = strcspn(p, ",");
		fprintf(fp, " %s%.*s,", n == 1 ? "-" : "--", (int)n, p);
		p += n + (p[n] == ',');
	}
	fprintf(fp, " -q, -h.\n");
}

/* The keys a command's --set may change: listed with their defaults, or
 * (run, config, sweep: every key) a pointer to --help-keys. */
static void print_keys(FILE *fp, const command *cmd)
{
	const char *keys = command_keys(cmd);

	if (!strstr(cmd->options, "set"))
		return;
	if (!keys) {
		fprintf(fp, "  --set keys: every parameter key (poolreps --help-keys).\n");
		return;
	}
	fprintf(fp, "\n");
	pr_config_help(pr_exp_config, keys, fp);
}

static void common_options(FILE *fp)
{
	fprintf(fp,
	        "\nCommon options (a command takes those its Accepts line lists, each at\n"
	        "most once except --set; any other is refused):\n"
	        "  -c FILE              parameter file (INI)\n"
	        "  --set SECTION.KEY=V  override one parameter (repeatable)\n"
	        "  --seed N             master seed (experiment.seed)\n"
	        "  -i FILE, -o FILE     input (default stdin) and output (default stdout)\n"
	        "  -q                   quiet: no progress, no summary line\n"
	        "  --progress           run: progress lines on stderr when it is no terminal\n"
	        "                       (batch logs; a failure's line then follows them)\n"
	        "  -h, --help           this help; after a COMMAND, that command's usage\n"
	        "  --help-keys          every parameter key with default, unit and range\n"
	        "  --version            print the version and exit\n"
	        "\nExit codes: 0 ok, 1 bad usage or parameter, 2 I/O or malformed CSV,\n"
	        "  3 numerical failure, 4 out of memory, 128 + N stopped by signal N\n"
	        "  (130 SIGINT, 143 SIGTERM, 129 SIGHUP, 131 SIGQUIT, 141 SIGPIPE, 153 SIGXFSZ).\n");
}

/* poolreps --help (cmd NULL): every command and the common options;
 * poolreps CMD --help, poolreps help CMD: that command, its options and
 * the keys it reads. */
static void usage(FILE *fp, const command *cmd)
{
	size_t i;

	if (cmd) {
		fprintf(fp, "Usage: %s\n", cmd->usage);
		print_options(fp, cmd->options);
		print_keys(fp, cmd);
	} else {
		fprintf(fp, "Usage: poolreps CONFIG | poolreps COMMAND [options] | poolreps help [COMMAND]\n"
		            "\nCommands:\n");
		for (i = 0; i < NCOMMANDS; ++i) {
			fprintf(fp, "  %s\n", commands[i].usage);
			print_options(fp, commands[i].options);
		}
	}
	common_options(fp);
	if (!cmd)
		fprintf(fp, "\nParameter keys: poolreps --help-keys lists them all (also docs/parameters.md\n"
		            "and the man page).\n");
}

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

/* The one error line: escaped like every library message (pr_err). */
static int fail(const char *msg)
{
	char line[PR_ERRLEN];

	pr_err(line, PR_EINVAL, "%s", msg);
	fprintf(stderr, "poolreps: %s\n", line);
	return 1;
}

/* After --help or --version: report a failed write to stdout. */
static int stdout_done(void)
{
	errno = 0;
	if (fflush(stdout) == 0 && !ferror(stdout))
		return 0;
	fprintf(stderr, "poolreps: <stdout>: write error: %s\n", strerror(errno ? errno : EIO));
	return 2;
}

/* The name an option has in the command table ("c", "set", "trace"). */
static const char *option_name(int c)
{
	static char letter[2];
	size_t i;

	if (c < 256) {
		letter[0] = (char)c;
		return letter;
	}
	for (i = 0; longopts[i].name; ++i)
		if (longopts[i].val == c)
			return longopts[i].name;
	return "?";
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

int main(int argc, char **argv)
{
	pr_cmd_args a;
	pr_config cfg;
	progress_state prog;
	struct sigaction sa;
	sigset_t held;
	const command *cmd = NULL;
	const char *config_path = NULL, *seed = NULL;
	char err[PR_ERRLEN] = "", msg[PR_ERRLEN + 64], note[PR_ERRLEN] = "";
	char **orig, **sets, **grids;
	int *used, nsets = 0, nused = 0, help = 0, progress_lines = 0, c, rc, i, k;
	struct timespec t0;
	clock_t c0 = clock();
	size_t j;

	clock_gettime(CLOCK_MONOTONIC, &t0);
	gsl_set_error_handler_off();
	memset(&sa, 0, sizeof sa);
	sa.sa_handler = on_signal;
	sigemptyset(&sa.sa_mask);
	for (i = 0; pr_fatal_signals[i]; ++i)
		sigaddset(&sa.sa_mask, pr_fatal_signals[i]);
	for (i = 0; pr_fatal_signals[i]; ++i)
		sigaction(pr_fatal_signals[i], &sa, NULL);
	memset(&a, 0, sizeof a);
	/* getopt_long permutes argv: provenance records the order as typed */
	orig = calloc(3 * ((size_t)argc + 1), sizeof *orig);
	used = calloc((size_t)argc + 1, sizeof *used);
	if (!orig || !used) {
		free(orig);
		fail("out of memory");
		return pr_exit_code(PR_ENOMEM);
	}
	memcpy(orig, argv, (size_t)argc * sizeof *orig);
	sets = orig + argc + 1;
	grids = sets + argc + 1;
	a.grid = grids;
	a.argc = argc;
	a.argv = orig;
	a.note = note;
	opterr = 0;
#define FAIL(...) do { snprintf(msg, sizeof msg, __VA_ARGS__); free(orig); free(used); return fail(msg); } while (0)
	while ((c = getopt_long(argc, argv, ":c:i:o:qh", longopts, NULL)) != -1) {
		switch (c) {
		case 'c': config_path = optarg; break;
		case 'i': a.input = optarg; break;
		case 'o': a.output = optarg; break;
		case 'q': a.quiet = 1; break;
		case O_PROGRESS: progress_lines = 1; break;
		case 'h': help = 1; break;
		case O_HELP_KEYS:
			pr_config_help(pr_exp_config, NULL, stdout);
			free(orig);
			free(used);
			return stdout_done();
		case O_VERSION:
			printf("poolreps %s\n", pr_version());
			free(orig);
			free(used);
			return stdout_done();
		case O_SET: sets[nsets++] = optarg; break;
		case O_SEED: seed = optarg; break;
		case O_TRACE: a.trace = optarg; break;
		case O_TRAIN: a.train = optarg; break;
		case O_TEST: a.test = optarg; break;
		case O_TARGET: a.target = optarg; break;
		case O_WEIGHT: a.weight = optarg; break;
		case O_LEAVES: a.leaves = optarg; break;
		case O_SAVE: a.save = optarg; break;
		case O_LOAD: a.load = optarg; break;
		case O_RETURN: a.ret = optarg; break;
		case O_FEATURES: a.features = optarg; break;
		case O_BASE: a.base = optarg; break;
		case O_SUMMARY: a.summary = optarg; break;
		case O_STATE: a.state = optarg; break;
		case O_ACTION: a.action = optarg; break;
		case O_GRID: grids[a.ngrid++] = optarg; break;
		case O_SPLIT: a.split = optarg; break;
		case O_MISSING: a.missing = optarg; break;
		case O_KEEP: a.keep = 1; break;
		case O_OLD_MEAN: a.old_mean = optarg; break;
		case O_EPSILON: {
			char *end;
			a.epsilon = strtod(optarg, &end);
			if (end == optarg || *end || !(a.epsilon > 0) || a.epsilon > 1e6)
				FAIL("--epsilon %.40s: must be a number > 0 and <= 1e6", optarg);
			a.epsilon_set = 1;
			break;
		}
		case O_SAMPLE: {
			char *end;
			a.sample = strtol(optarg, &end, 10);
			if (end == optarg || *end || a.sample < 1 || a.sample > 1000000)
				FAIL("--sample %.40s: must be an integer in 1..1000000", optarg);
			break;
		}
		case ':':
			FAIL("option %s needs a value (see poolreps --help)", argv[optind - 1]);
		default:
			/* in a group such as -qZ, optind may not have moved past it yet */
			if (optopt)
				FAIL("unknown option -%c (see poolreps --help)", optopt);
			FAIL("unknown option %s (see poolreps --help)", argv[optind - 1]);
		}
		if (c != 'q' && c != 'h') {
			/* a value given twice would silently drop the first (--set and
			 * --grid repeat by design) */
			for (k = 0; c != O_SET && c != O_GRID && k < nused; ++k)
				if (used[k] == c)
					FAIL("option %s%s given twice%s", c < 256 ? "-" : "--", option_name(c),
					     c == 'c' ? ": give one parameter file (--set overrides single keys)" : "");
			used[nused++] = c;
		}
	}

	/* poolreps help [COMMAND]: that command's --help */
	if (optind < argc && strcmp(argv[optind], "help") == 0) {
		help = 1;
		if (++optind < argc) {
			for (j = 0; j < NCOMMANDS && strcmp(argv[optind], commands[j].name) != 0; ++j)
				;
			if (j == NCOMMANDS)
				FAIL("help: unknown command '%.60s' (see poolreps --help)", argv[optind]);
			if (optind + 1 < argc)
				FAIL("help: unexpected argument '%.60s'", argv[optind + 1]);
		} else {
			optind = argc;
		}
	}
	/* The first operand names a command; anything else is a parameter file. */
	if (optind < argc) {
		for (j = 0; j < NCOMMANDS; ++j)
			if (strcmp(argv[optind], commands[j].name) == 0)
				cmd = &commands[j];
		if (cmd)
			++optind;
		else
			cmd = &commands[0];
	}
	if (help) {
		usage(stdout, cmd);
		free(orig);
		free(used);
		return stdout_done();
	}
	if (!cmd)
		FAIL("Usage: poolreps CONFIG | poolreps COMMAND [options] (see poolreps --help)");
	if (cmd->fn == pr_cmd_run) {
		if (optind < argc && config_path)
			FAIL("run: two parameter files (%s and -c %s): give one", argv[optind], config_path);
		if (optind < argc)
			config_path = argv[optind++];
		if (!config_path)
			FAIL("run: no parameter file given (poolreps CONFIG)");
	} else if (cmd->fn == pr_cmd_sweep && !a.missing && optind < argc) {
		config_path = argv[optind++];
	} else if (cmd->fn == pr_cmd_merge || cmd->fn == pr_cmd_collect) {
		a.ninputs = argc - optind;
		a.inputs = argv + optind;
		optind = argc;
	}
	if (optind < argc)
		FAIL("%s: unexpected argument '%.60s'", cmd->name, argv[optind]);
	for (k = 0; k < nused + (nsets > 0); ++k) {
		const char *name = option_name(k < nused ? used[k] : O_SET);
		const char *p = strstr(cmd->options, name);
		size_t n = strlen(name);
		if (!(p && (p == cmd->options || p[-1] == ',') && (p[n] == '\0' || p[n] == ',')))
			FAIL("%s: option %s%s does not apply (see poolreps %s --help)", cmd->name,
			     n == 1 ? "-" : "--", name, cmd->name);
	}
	/* a key the command never reads would be ignored: refuse it */
	for (i = 0; command_keys(cmd) && i < nsets; ++i) {
		char key[64];
		arg_key(sets[i], key, sizeof key);
		if (!pr_config_key_listed(command_keys(cmd), key))
			FAIL("%s: --set %s does not apply (see poolreps %s --help)", cmd->name, key, cmd->name);
	}
	if (command_keys(cmd) && seed && !pr_config_key_listed(command_keys(cmd), "experiment.seed"))
		FAIL("%s: option --seed does not apply (see poolreps %s --help)", cmd->name, cmd->name);
	/* -q silences the progress --progress asks for */
	if (progress_lines && a.quiet)
		FAIL("%s: -q and --progress contradict: give one", cmd->name);
	/* sweep --missing only reads SWEEP_DIR: every other option would be ignored */
	if (a.missing && (a.output || a.ngrid || nsets || seed || a.split))
		FAIL("sweep: --missing takes no other option (%s given)", a.output ? "-o" : a.ngrid ?
		     "--grid" : nsets ? "--set" : seed ? "--seed" : "--split");
#undef FAIL
	free(used);
	a.command = cmd->name;
	graceful = cmd->fn == pr_cmd_run || cmd->fn == pr_cmd_merge || cmd->fn == pr_cmd_sweep ||
	           cmd->fn == pr_cmd_collect;
	if (graceful)
		make_stop_timer();
	memset(&prog, 0, sizeof prog);
	prog.tty = isatty(STDERR_FILENO);
	/* plain lines only when asked: a failure must stay one stderr line */
	if (!a.quiet && (prog.tty || progress_lines)) {
		prog.t0 = t0;
		prog.last_decile = -1;
		a.progress.fn = on_progress;
		a.progress.user = &prog;
	}

	pr_config_init(&cfg, pr_exp_config);
	rc = PR_OK;
	if (config_path)
		rc = pr_config_load(&cfg, config_path, err);
	for (i = 0; rc == PR_OK && i < nsets; ++i)
		rc = pr_config_set(&cfg, sets[i], err);
	if (rc == PR_OK && seed) {
		char buf[96];
		snprintf(buf, sizeof buf, "experiment.seed=%.60s", seed);
		rc = pr_config_set(&cfg, buf, err);
		if (rc)
			pr_err(err, rc, "--seed %.60s: must be an integer in 0..4294967295", seed);
	}
	if (rc == PR_OK)
		rc = pr_config_validate(&cfg, err);
	/* config refuses what a run would: a variant the experiment does not have */
	if (rc == PR_OK && cmd->fn == pr_cmd_config) {
		pr_variants variants;
		rc = pr_exp_variants(&cfg, &variants, err);
	}
	/* a run never reads another experiment's keys: a --set or --grid of one
	 * would change nothing (a parameter file may hold them: one serves several) */
	for (i = 0; rc == PR_OK && !command_keys(cmd) && cmd->fn != pr_cmd_config &&
	            i < nsets + a.ngrid; ++i) {
		char key[64];
		arg_key(i < nsets ? sets[i] : grids[i - nsets], key, sizeof key);
		if (pr_config_key_elsewhere(&cfg, key))
			rc = pr_err(err, PR_EINVAL, "%s: %s %s does not apply: experiment %s never reads it",
			            cmd->name, i < nsets ? "--set" : "--grid", key, cfg.run.name);
	}
	if (rc == PR_OK)
		rc = cmd->fn(&cfg, &a, err);
	/* everything is cleaned up or in place: a late signal must not add a
	 * second line to the one below */
	pr_cleanup_hold(&held);
	free(orig);
	/* an error must not land at the end of an unfinished bar */
	if (!a.quiet && prog.open)
		fputs("\r\033[K", stderr);
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
	else if (!a.quiet && note[0])
		fprintf(stderr, "poolreps: %s\n", note);
	if (cmd->fn == pr_cmd_run && !a.quiet && !pr_interrupted)
		print_done(&t0, c0);
	return 0;
}
