/* The paper's ThreadWaiter (described and emulated by
 * sync/win_event_faithful.hpp on sync/win32_emulation.hpp), on which Spin
 * must find the lost wake-up.
 *
 * A shared counter starts at the number of threads; each arriving thread
 * atomically decrements it (InterlockedDecrement); the thread that brings it
 * to zero stores the thread count back (InterlockedExchange) and sets a
 * manual-reset event (SetEvent); every other thread waits on the event
 * (WaitForSingleObject); then every thread, whichever branch it took, resets
 * the event (ResetEvent).
 *
 * The event, with Windows' semantics as the emulation reproduces them:
 * SetEvent makes it signalled and releases every thread waiting at that
 * moment (even if ResetEvent follows before the thread runs again); a wait on
 * a signalled event returns at once; ResetEvent releases nobody. The check
 * "signalled?" and going to sleep are one atomic step (the emulation's futex
 * compare on the event's state word).
 *
 * TIMEOUT (spin -D):
 *   0  WaitForSingleObject(event, INFINITE): a lost wake-up leaves a thread
 *      asleep forever; Spin reports an invalid end state.
 *   1  the paper's 1000 ms timeout, counted, and modelled as expiring only
 *      when nothing else in the system can move (Promela's `timeout`): no
 *      phase of the paper's workload comes near 1000 ms, so a timeout is the
 *      consequence of a lost wake-up, never of a slow phase. Spin reports a
 *      thread that leaves a phase before every thread arrived at it.
 * Each step prints what it does, so that the trail reads as the interleaving.
 */
#ifndef PARTICIPANTS
#define PARTICIPANTS 2
#endif
#ifndef PHASES
#define PHASES 2
#endif
#ifndef TIMEOUT
#define TIMEOUT 0
#endif

short count = PARTICIPANTS;    /* the interlocked counter */
bool signalled = false;        /* the manual-reset event */
bool waiting[PARTICIPANTS];    /* asleep in WaitForSingleObject */

/* Ghosts: arrivals per phase, and the timeouts taken. */
byte arrived[PHASES];
byte timeouts = 0;

inline set_event() {
  d_step {
    byte index = 0;
    signalled = true;
    do
    :: index < PARTICIPANTS -> waiting[index] = false; index++
    :: else -> break
    od;
    index = 0
  }
}

inline wait_for_event() {
  atomic {
    if
    :: signalled -> printf("thread %d: WaitForSingleObject: event set, returns\n", _pid)
    :: else -> waiting[_pid] = true; printf("thread %d: WaitForSingleObject: event not set, sleeps\n", _pid)
    fi
  }
  if
  :: atomic { !waiting[_pid] -> skip }
#if TIMEOUT
  :: atomic {
      timeout && waiting[_pid] -> waiting[_pid] = false; timeouts++;
      printf("thread %d: WaitForSingleObject: WAIT_TIMEOUT (nothing else can run)\n", _pid)
    }
#endif
  fi
}

active [PARTICIPANTS] proctype thread() {
  byte phase = 0;
  bool last = false;
  do
  :: phase == PHASES -> break
  :: else ->
    atomic {
      arrived[phase]++;
      count--;
      last = (count == 0);
      printf("thread %d: phase %d: InterlockedDecrement -> %d\n", _pid, phase, count)
    }
    if
    :: last ->
      count = PARTICIPANTS;
      printf("thread %d: InterlockedExchange(count, %d)\n", _pid, PARTICIPANTS);
      set_event();
      printf("thread %d: SetEvent\n", _pid);
      last = false
    :: else -> wait_for_event()
    fi;
    signalled = false;
    printf("thread %d: ResetEvent\n", _pid);
    /* No thread leaves phase p before every thread arrived at p. */
    assert(arrived[phase] == PARTICIPANTS);
    printf("thread %d: leaves phase %d\n", _pid, phase);
    phase++
  od
}
