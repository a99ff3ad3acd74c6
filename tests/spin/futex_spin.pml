/* futex_spin's sleeper protocol (sync/futex_spin.hpp), as the code does it.
 *
 * Shared: the phase word (remaining, sense, sleepers) and the kernel's wait
 * queue on `sense` (blocked[]). Each participant: flip its own sense, arrive
 * with one atomic decrement; the last arriver rearms the counter, stores the
 * new sense and wakes every sleeper when it reads a non-zero sleepers count;
 * the others spin (one read of the sense at a moment the scheduler picks, or
 * none: the bounded budget), then announce themselves in sleepers and
 * FUTEX_WAIT on the old sense until the sense is theirs. Comments (1)..(8)
 * are the edges of the header. Sequential consistency throughout: see
 * README.md. Each step prints what it does (pan ignores printf; a trail
 * replay shows it).
 *
 * Macros (spin -D): PARTICIPANTS (2..4), PHASES (>= 2: rearming and sense
 * reversal), LATE (participant PARTICIPANTS-1 arrives at phase 0 only once
 * every other participant has announced itself asleep), SPURIOUS (how many
 * times in a run FUTEX_WAIT may return with no wake-up, as on EINTR: a
 * bounded number, since an endless supply would also rescue a lost wake-up),
 * and the deliberate bugs of the negative controls:
 *   BUG_WAKE_CHECK_FIRST  the last arriver reads sleepers before it stores the
 *                         sense: a sleeper can announce itself and block in
 *                         between, and nobody wakes it (lost wake-up);
 *   BUG_WAIT_ONCE         `if` instead of `while` around FUTEX_WAIT: a wake-up
 *                         meant for the previous phase (or EINTR) lets a
 *                         participant leave its phase early.
 */
#ifndef PARTICIPANTS
#define PARTICIPANTS 3
#endif
#ifndef PHASES
#define PHASES 2
#endif
#ifndef LATE
#define LATE 0
#endif
#ifndef SPURIOUS
#define SPURIOUS 1
#endif
#ifndef BUG_WAKE_CHECK_FIRST
#define BUG_WAKE_CHECK_FIRST 0
#endif
#ifndef BUG_WAIT_ONCE
#define BUG_WAIT_ONCE 0
#endif

/* The phase word. */
byte remaining = PARTICIPANTS;   /* arrivals still missing in this phase */
bit sense = 0;                   /* the futex word */
byte sleepers = 0;

/* The kernel: who sleeps in FUTEX_WAIT on `sense`. */
bool blocked[PARTICIPANTS];

/* Spurious returns FUTEX_WAIT may still make in this run. */
byte spurious = SPURIOUS;

/* Ghosts: arrivals per phase (safety), participants done (liveness). */
byte arrived[PHASES];
byte finished = 0;

/* Steps: every atomic block below holds one access to the protocol's shared
 * state (a load, a store or a read-modify-write: the interleaving point; ghost
 * variables do not count) and the local bookkeeping around it, so that states
 * are stored only where another participant could act. */

/* FUTEX_WAIT(&sense, expected), inside an atomic block: compares and blocks,
 * atomically with respect to FUTEX_WAKE, and returns when woken; returns at
 * once when the word differs (EAGAIN) or, while the spurious budget lasts,
 * without a wake-up (EINTR: returning at once is as general as returning
 * later, since the caller may be delayed before it reads the word again). */
inline futex_wait(expected) {
  if
  :: sense == (expected) ->
    if
    :: spurious > 0 -> spurious--;
      printf("participant %d: FUTEX_WAIT returns at once (EINTR)\n", _pid)
    :: true -> blocked[_pid] = true;
      printf("participant %d: FUTEX_WAIT(sense == %d): sleeps\n", _pid, expected);
      !blocked[_pid];
      printf("participant %d: woken\n", _pid)
    fi
  :: else -> printf("participant %d: FUTEX_WAIT: sense is no longer %d (EAGAIN)\n", _pid, expected)
  fi
}

/* FUTEX_WAKE(&sense, INT_MAX), inside an atomic block: every thread blocked
 * on the word. */
inline futex_wake() {
  printf("participant %d: FUTEX_WAKE\n", _pid);
  index = 0;
  do
  :: index < PARTICIPANTS -> blocked[index] = false; index++
  :: else -> break
  od;
  index = 0
}

/* Leaving phase p: no participant leaves it before every participant arrived
 * at it (checked in the step that saw the phase end). */
inline leave() {
  printf("participant %d: leaves phase %d (arrivals %d)\n", _pid, phase, arrived[phase]);
  assert(arrived[phase] == PARTICIPANTS);
  phase++
}

#if LATE
/* The late arriver: the last participant arrives at phase 0 only once every
 * other participant has announced itself asleep (5). */
#define MAY_ARRIVE (phase != 0 || _pid != PARTICIPANTS - 1 || sleepers == PARTICIPANTS - 1)
#else
#define MAY_ARRIVE true
#endif

active [PARTICIPANTS] proctype participant() {
  byte phase = 0;
  bit my_sense = 0;   /* the sense value that ends the current phase */
  bool last = false;
  byte index = 0;
  do
  :: atomic { phase == PHASES -> finished++; break }
  :: phase < PHASES ->
    /* (1) fetch_sub; the ghost counts the arrival in the same step. */
    atomic {
      MAY_ARRIVE;
      my_sense = 1 - my_sense;
      arrived[phase]++;
      last = (remaining == 1);
      remaining--;
      printf("participant %d: phase %d: arrives, remaining %d\n", _pid, phase, remaining)
    };
    if
    :: atomic { last -> last = false; remaining = PARTICIPANTS }   /* (2) rearm */
#if BUG_WAKE_CHECK_FIRST
      /* Reads sleepers, then releases: a sleeper that announces itself and
       * blocks in between is never woken. */
      if
      :: sleepers != 0 -> atomic { sense = my_sense; printf("participant %d: sense = %d\n", _pid, sense) };
        atomic { futex_wake(); leave() }
      :: atomic { sleepers == 0 -> printf("participant %d: no sleeper yet: no FUTEX_WAKE\n", _pid) };
        atomic { sense = my_sense; printf("participant %d: sense = %d\n", _pid, sense); leave() }
      fi
#else
      atomic { sense = my_sense; printf("participant %d: sense = %d\n", _pid, sense) }  /* (3) release */
      if
      :: sleepers != 0 -> atomic { futex_wake(); leave() }          /* (7), FUTEX_WAKE */
      :: atomic { sleepers == 0 -> leave() }                        /* (7) */
      fi
#endif
    :: atomic { !last && sense == my_sense -> leave() }             /* (4) the spin saw it */
    :: atomic {                           /* the spin budget ran out: (5) announce, then sleep */
        !last -> sleepers++;
        printf("participant %d: spin budget spent: sleepers %d\n", _pid, sleepers)
      }
#if BUG_WAIT_ONCE
      if
      :: atomic { sense != my_sense -> futex_wait(1 - my_sense); leave() }
      :: atomic { sense == my_sense -> leave() }
      fi;
#else
      do
      :: atomic { sense != my_sense -> futex_wait(1 - my_sense) }   /* (6), FUTEX_WAIT */
      :: atomic { sense == my_sense -> leave(); break }             /* (6) */
      od;
#endif
      sleepers--                                                    /* (8) */
    fi
  od
}

/* No lost wake-up: every participant returns from its last phase. */
ltl every_participant_proceeds { <> (finished == PARTICIPANTS) }
