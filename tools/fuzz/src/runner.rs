//! Runs one call sequence on a fresh instance and checks every answer against the oracle and
//! the properties: illegal calls and invalid arguments refused, every fmi2Error with a logged
//! message, no NaN or infinity after fmi2OK, states that round-trip bit for bit, damaged states
//! refused, and after the sequence, fmi2Reset equal to a fresh instance. The answers are
//! recorded (statuses and value bits) so that two runs can be compared.

use fmi2_ffi::Status;
use fmu_import::{FmuState, ImportError, Instance};

use crate::oracle::{after_error, after_success, legal, Phase};
use crate::sequence::{Call, Damage, StepAt};
use crate::target::{BaseType, Target};

/// Why a sequence failed: the call (index in the sequence) and what went wrong.
#[derive(Debug, Clone, PartialEq)]
pub struct Failure {
    pub call: Option<usize>,
    pub message: String,
}

/// The recorded answers of a run: one hash per call of its status and returned values.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Trace(pub Vec<u64>);

/// What a run reached, to show that the sequences get past the first errors.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Reached {
    /// Calls answered fmi2OK (or fmi2Warning).
    pub ok: u64,
    /// Steps answered fmi2OK.
    pub steps: u64,
    /// States restored with fmi2OK (and checked value for value).
    pub restores: u64,
    /// Damaged or random states refused.
    pub refused_states: u64,
}

/// A saved FMU state and what the master knew when it was saved.
struct Slot {
    state: FmuState,
    phase: Phase,
    time: f64,
    /// The bits of every Real, read right after the save (when a get was legal and harmless).
    reals: Option<Vec<u64>>,
}

/// The master's side of one run.
struct Run<'a> {
    target: &'a Target,
    instance: Instance,
    phase: Phase,
    time: f64,
    slots: Vec<Slot>,
    trace: Vec<u64>,
    real_vrs: Vec<u32>,
    reached: Reached,
}

fn hash(words: impl IntoIterator<Item = u64>) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for w in words {
        for b in w.to_le_bytes() {
            h ^= u64::from(b);
            h = h.wrapping_mul(0x0000_0100_0000_01b3);
        }
    }
    h
}

fn status_code(result: &Result<Status, ImportError>) -> u64 {
    match result {
        Ok(status) => *status as u64,
        Err(ImportError::Call { status, .. }) => *status as u64,
        Err(_) => 99,
    }
}

/// Runs `calls` on a fresh instance of `target`.
pub fn run(target: &Target, calls: &[Call], name: &str) -> Result<(Trace, Reached), Failure> {
    run_with(target, calls, name, &|_| {})
}

/// [`run`], telling `progress` the index of each call before it is made (the child process
/// reports it, so that the parent's timeout applies to each call, not to the whole sequence).
pub fn run_with(
    target: &Target,
    calls: &[Call],
    name: &str,
    progress: &(dyn Fn(usize) + Sync),
) -> Result<(Trace, Reached), Failure> {
    let instance = target
        .fmu
        .instantiate(name, false)
        .map_err(|e| Failure { call: None, message: format!("fmi2Instantiate failed: {e}") })?;
    let mut run = Run {
        target,
        instance,
        phase: Phase::Instantiated,
        time: 0.0,
        slots: Vec::new(),
        trace: Vec::new(),
        real_vrs: target.real_vrs(),
        reached: Reached::default(),
    };
    for (index, call) in calls.iter().enumerate() {
        progress(index);
        run.call(call).map_err(|message| Failure { call: Some(index), message })?;
    }
    progress(calls.len());
    run.reset_equals_fresh().map_err(|message| Failure { call: None, message })?;
    Ok((Trace(run.trace), run.reached))
}

impl Run<'_> {
    fn call(&mut self, call: &Call) -> Result<(), String> {
        let log_start = self.instance.log_len();
        let legal_now = legal(call, self.phase);
        let must_fail = !legal_now || self.invalid_arguments(call);
        let (result, values) = self.execute(call)?;
        if std::env::var_os("FMU_FUZZ_TRACE").is_some() {
            // Replaying one seed by hand: every call with its answer, on stderr.
            let answer = match &result {
                Ok(status) => status.name().to_string(),
                Err(e) => e.to_string(),
            };
            eprintln!("{:?} {call} -> {answer}", self.phase);
        }
        self.trace.push(hash([status_code(&result)].into_iter().chain(values.iter().copied())));
        match &result {
            Ok(_) if must_fail => {
                return Err(format!(
                    "accepted although it must fail ({} in phase {:?})",
                    if legal_now { "invalid arguments" } else { "illegal call" },
                    self.phase
                ))
            }
            Ok(_) => {
                self.reached.ok += 1;
                match call {
                    Call::DoStep { .. } => self.reached.steps += 1,
                    Call::RestoreState(_) | Call::SerializeRoundTrip(_) if !self.slots.is_empty() => {
                        self.reached.restores += 1
                    }
                    _ => {}
                }
                self.phase = after_success(call, self.phase)
            }
            Err(ImportError::Call { status: Status::Error, messages, .. }) => {
                let logged = self.instance.log_records()[log_start..]
                    .iter()
                    .any(|r| r.status == Status::Error && !r.message.trim().is_empty());
                if !logged {
                    return Err(format!("fmi2Error without a logged message ({messages:?})"));
                }
                if matches!(call, Call::CorruptState { .. } | Call::Garbage(_)) {
                    self.reached.refused_states += 1;
                }
                self.phase = after_error(call, self.phase);
            }
            Err(other) => return Err(format!("unexpected answer: {other}")),
        }
        if result.is_ok() {
            self.after_ok(call)?;
        }
        Ok(())
    }

    /// Arguments the FMU must refuse whatever the phase: non-finite or out-of-range values,
    /// unknown references, values of variables that cannot be set now, booleans other than 0
    /// and 1, bad steps, damaged states.
    fn invalid_arguments(&self, call: &Call) -> bool {
        let var = |vr: u32| self.target.variables.iter().find(|v| v.vr == vr);
        let settable = |vr: u32, base: BaseType| {
            var(vr).is_some_and(|v| {
                v.base == base
                    && v.settable
                    && match self.phase {
                        Phase::StepComplete => v.input || v.tunable,
                        _ => true,
                    }
            })
        };
        match call {
            Call::SetReal(values) => values.iter().any(|&(vr, x)| {
                !settable(vr, BaseType::Real)
                    || !x.is_finite()
                    || var(vr).is_some_and(|v| v.min.is_some_and(|lo| x < lo) || v.max.is_some_and(|hi| x > hi))
            }),
            Call::SetInteger(values) => values.iter().any(|&(vr, n)| {
                !settable(vr, BaseType::Integer)
                    || var(vr).is_some_and(|v| {
                        let n = f64::from(n);
                        v.min.is_some_and(|lo| n < lo)
                            || v.max.is_some_and(|hi| n > hi)
                            || v.enumeration_items.is_some_and(|items| n < 1.0 || n > f64::from(items))
                    })
            }),
            Call::SetBoolean(values) => {
                values.iter().any(|&(vr, b)| !settable(vr, BaseType::Boolean) || !(b == 0 || b == 1))
            }
            Call::SetString(values) => values.iter().any(|&(vr, _)| !settable(vr, BaseType::String)),
            Call::GetReal(vrs) => vrs.iter().any(|&vr| var(vr).is_none_or(|v| v.base != BaseType::Real)),
            Call::GetInteger(vrs) => vrs.iter().any(|&vr| var(vr).is_none_or(|v| v.base != BaseType::Integer)),
            Call::GetBoolean(vrs) => vrs.iter().any(|&vr| var(vr).is_none_or(|v| v.base != BaseType::Boolean)),
            Call::GetString(vrs) => vrs.iter().any(|&vr| var(vr).is_none_or(|v| v.base != BaseType::String)),
            Call::DoStep { at, h, no_set_prior } => {
                let wrong_point = match at {
                    StepAt::Now => false,
                    StepAt::Offset(d) => d.abs() > 1e-6 * self.time.abs().max(1.0),
                    StepAt::Value(x) => !x.is_finite() || (x - self.time).abs() > 1e-6 * self.time.abs().max(1.0),
                };
                !(*h > 0.0 && h.is_finite())
                    || *h > 86_400.0
                    || wrong_point
                    || !(*no_set_prior == 0 || *no_set_prior == 1)
            }
            Call::Setup { tolerance_defined, start, stop_defined, stop } => {
                !(*tolerance_defined == 0 || *tolerance_defined == 1)
                    || !(*stop_defined == 0 || *stop_defined == 1)
                    || !start.is_finite()
                    || (*stop_defined == 1 && !(stop.is_finite() && stop >= start))
            }
            Call::DebugLogging(on) => !(*on == 0 || *on == 1),
            Call::Garbage(_) | Call::EventMode => true,
            _ => false,
        }
    }

    /// Makes the call; returns its result and the values it returned (as bits, for the trace).
    fn execute(&mut self, call: &Call) -> Result<(Result<Status, ImportError>, Vec<u64>), String> {
        let i = &mut self.instance;
        let mut values = Vec::new();
        let result = match call {
            Call::Setup { tolerance_defined, start, stop_defined, stop } => {
                let r = i.setup_experiment_raw(*tolerance_defined, 1e-6, *start, *stop_defined, *stop);
                if r.is_ok() {
                    self.time = *start;
                }
                r
            }
            Call::EnterInit => i.enter_initialization_mode(),
            Call::ExitInit => i.exit_initialization_mode(),
            Call::Terminate => i.terminate(),
            Call::Reset => {
                let r = i.reset();
                if r.is_ok() {
                    self.time = 0.0;
                }
                r
            }
            Call::SetReal(v) => {
                let (vrs, xs): (Vec<u32>, Vec<f64>) = v.iter().copied().unzip();
                i.set_real(&vrs, &xs)
            }
            Call::SetInteger(v) => {
                let (vrs, xs): (Vec<u32>, Vec<i32>) = v.iter().copied().unzip();
                i.set_integer(&vrs, &xs)
            }
            Call::SetBoolean(v) => {
                let (vrs, xs): (Vec<u32>, Vec<i32>) = v.iter().copied().unzip();
                i.set_boolean_raw(&vrs, &xs)
            }
            Call::SetString(v) => {
                let vrs: Vec<u32> = v.iter().map(|(vr, _)| *vr).collect();
                let xs: Vec<&str> = v.iter().map(|(_, s)| s.as_str()).collect();
                i.set_string(&vrs, &xs)
            }
            Call::GetReal(vrs) => {
                let mut out = vec![0.0; vrs.len()];
                let r = i.get_real(vrs, &mut out);
                if r.is_ok() {
                    if let Some(x) = out.iter().find(|x| !x.is_finite()) {
                        return Err(format!("fmi2GetReal returned {x} with fmi2OK"));
                    }
                    values.extend(out.iter().map(|x| x.to_bits()));
                }
                r
            }
            Call::GetInteger(vrs) => {
                let mut out = vec![0; vrs.len()];
                let r = i.get_integer(vrs, &mut out);
                values.extend(out.iter().map(|&n| n as u64));
                r
            }
            Call::GetBoolean(vrs) => {
                let mut out = vec![false; vrs.len()];
                let r = i.get_boolean(vrs, &mut out);
                values.extend(out.iter().map(|&b| u64::from(b)));
                r
            }
            Call::GetString(vrs) => match i.get_string(vrs) {
                Ok(strings) => {
                    values.extend(strings.iter().map(|s| s.len() as u64));
                    Ok(Status::Ok)
                }
                Err(e) => Err(e),
            },
            Call::DoStep { at, h, no_set_prior } => {
                let t = match at {
                    StepAt::Now => self.time,
                    StepAt::Offset(d) => self.time + d,
                    StepAt::Value(x) => *x,
                };
                let r = i.do_step_raw(t, *h, *no_set_prior);
                if r.is_ok() {
                    self.time = t + h;
                }
                r
            }
            Call::SaveState => return self.save_state(),
            Call::RestoreState(k) => return self.restore_state(*k),
            Call::FreeState(k) => {
                if self.slots.is_empty() {
                    return Ok((Ok(Status::Ok), values));
                }
                let slot = self.slots.remove(k % self.slots.len());
                i.free_state(slot.state)
            }
            Call::SerializeRoundTrip(k) => return self.serialize_round_trip(*k),
            Call::CorruptState { slot, damage } => return self.corrupt_state(*slot, damage),
            Call::Garbage(bytes) => match i.deserialize_state(bytes) {
                Ok(_) => return Err(format!("{} random bytes were accepted as a state", bytes.len())),
                Err(e) => Err(e),
            },
            Call::DebugLogging(on) => i.set_debug_logging_raw(*on),
            Call::Status => {
                let r = i.do_step_status();
                if r.is_ok() {
                    match i.last_successful_time() {
                        Ok(t) if !t.is_finite() => return Err(format!("fmi2GetRealStatus gave {t} with fmi2OK")),
                        Ok(t) => values.push(t.to_bits()),
                        Err(e) => return Ok((Err(e), values)),
                    }
                }
                r
            }
            Call::EventMode => i.enter_event_mode(),
        };
        Ok((result, values))
    }

    /// Every Real's bits, if the get succeeds; a get that fails must say why, and moves the
    /// instance to Error.
    fn read_all_reals(&mut self) -> Result<Option<Vec<u64>>, String> {
        let mut out = vec![0.0; self.real_vrs.len()];
        let log_start = self.instance.log_len();
        match self.instance.get_real(&self.real_vrs, &mut out) {
            Ok(_) => {
                if let Some((k, x)) = out.iter().enumerate().find(|(_, x)| !x.is_finite()) {
                    return Err(format!("Real vr {} = {x} after fmi2OK", self.real_vrs[k]));
                }
                Ok(Some(out.iter().map(|x| x.to_bits()).collect()))
            }
            Err(_) => {
                if self.instance.log_records().len() <= log_start {
                    return Err("fmi2GetReal failed without a logged message".into());
                }
                self.phase = Phase::Error;
                Ok(None)
            }
        }
    }

    /// After a successful step, every Real is finite (or the get that reads them says why not).
    fn after_ok(&mut self, call: &Call) -> Result<(), String> {
        if matches!(call, Call::DoStep { .. }) {
            if let Some(bits) = self.read_all_reals()? {
                self.trace.push(hash(bits));
            }
        }
        Ok(())
    }

    fn save_state(&mut self) -> Result<(Result<Status, ImportError>, Vec<u64>), String> {
        let state = match self.instance.get_state() {
            Ok(state) => state,
            Err(e) => return Ok((Err(e), Vec::new())),
        };
        let (phase, time) = (self.phase, self.time);
        let reals = if matches!(phase, Phase::StepComplete | Phase::Terminated | Phase::Error) {
            self.read_all_reals()?
        } else {
            None
        };
        // A failed read moved the instance to Error after the save: the state keeps its phase.
        self.slots.push(Slot { state, phase, time, reals });
        Ok((Ok(Status::Ok), Vec::new()))
    }

    fn restore_state(&mut self, k: usize) -> Result<(Result<Status, ImportError>, Vec<u64>), String> {
        if self.slots.is_empty() {
            return Ok((Ok(Status::Ok), Vec::new()));
        }
        let k = k % self.slots.len();
        let result = self.instance.set_state(&self.slots[k].state);
        if result.is_ok() {
            self.phase = self.slots[k].phase;
            self.time = self.slots[k].time;
            self.check_restored_values(k)?;
        }
        Ok((result, Vec::new()))
    }

    /// After a restore, every Real reads back as it was read right after the save.
    fn check_restored_values(&mut self, k: usize) -> Result<(), String> {
        let Some(expected) = self.slots[k].reals.clone() else { return Ok(()) };
        match self.read_all_reals()? {
            Some(bits) if bits == expected => Ok(()),
            Some(bits) => {
                let at = bits.iter().zip(&expected).position(|(a, b)| a != b).unwrap_or(0);
                Err(format!(
                    "restored state reads vr {} = {} instead of {}",
                    self.real_vrs[at],
                    f64::from_bits(bits[at]),
                    f64::from_bits(expected[at])
                ))
            }
            None => Err("a restored state could not be read although it could when saved".into()),
        }
    }

    fn serialize_round_trip(&mut self, k: usize) -> Result<(Result<Status, ImportError>, Vec<u64>), String> {
        if self.slots.is_empty() {
            return Ok((Ok(Status::Ok), Vec::new()));
        }
        let k = k % self.slots.len();
        let bytes = self.instance.serialize_state(&self.slots[k].state).map_err(|e| format!("serialize: {e}"))?;
        let again = self.instance.serialize_state(&self.slots[k].state).map_err(|e| format!("serialize: {e}"))?;
        if bytes != again {
            return Err("serializing one state twice gave different bytes".into());
        }
        let copy = self.instance.deserialize_state(&bytes).map_err(|e| format!("deserialize of fresh bytes: {e}"))?;
        let result = self.instance.set_state(&copy);
        let (phase, time, reals) = (self.slots[k].phase, self.slots[k].time, self.slots[k].reals.clone());
        self.slots.push(Slot { state: copy, phase, time, reals });
        if result.is_ok() {
            self.phase = phase;
            self.time = time;
            self.check_restored_values(self.slots.len() - 1)?;
        }
        Ok((result, vec![bytes.len() as u64]))
    }

    fn corrupt_state(&mut self, k: usize, damage: &Damage) -> Result<(Result<Status, ImportError>, Vec<u64>), String> {
        if self.slots.is_empty() {
            return Ok((Ok(Status::Ok), Vec::new()));
        }
        let k = k % self.slots.len();
        let bytes = self.instance.serialize_state(&self.slots[k].state).map_err(|e| format!("serialize: {e}"))?;
        let mut damaged = bytes.clone();
        match damage {
            Damage::Flips(flips) => {
                for &(at, mask) in flips {
                    if !damaged.is_empty() {
                        let n = damaged.len();
                        damaged[at % n] ^= mask;
                    }
                }
            }
            Damage::Truncate(per_mille) => damaged.truncate(bytes.len() * per_mille / 1000),
            Damage::Append(extra) => damaged.extend_from_slice(extra),
        }
        if damaged == bytes {
            return Ok((Ok(Status::Ok), Vec::new()));
        }
        match self.instance.deserialize_state(&damaged) {
            Ok(_) => Err(format!("a damaged state ({damage:?}) was accepted")),
            Err(e) => Ok((Err(e), Vec::new())),
        }
    }

    /// fmi2Reset, then a short standard run, must answer exactly as a fresh instance does.
    fn reset_equals_fresh(&mut self) -> Result<(), String> {
        self.instance.reset().map_err(|e| format!("fmi2Reset at the end of the sequence: {e}"))?;
        let after_reset = standard_run(&mut self.instance, &self.real_vrs)?;
        let mut fresh = self.target.fmu.instantiate("fresh", false).map_err(|e| format!("fresh instance: {e}"))?;
        let fresh_run = standard_run(&mut fresh, &self.real_vrs)?;
        if after_reset != fresh_run {
            return Err("after fmi2Reset the instance answers differently from a fresh one".into());
        }
        self.trace.push(hash(after_reset));
        Ok(())
    }
}

/// Setup, initialisation and five 1 ms steps at the start values, every Real read after each.
fn standard_run(instance: &mut Instance, real_vrs: &[u32]) -> Result<Vec<u64>, String> {
    instance.initialize(0.0, &[]).map_err(|e| format!("initialisation at the start values: {e}"))?;
    let mut bits = Vec::new();
    let mut out = vec![0.0; real_vrs.len()];
    for k in 0..5 {
        instance.do_step(k as f64 * 1e-3, 1e-3).map_err(|e| format!("a 1 ms step at the start values: {e}"))?;
        instance.get_real(real_vrs, &mut out).map_err(|e| format!("reading the Reals: {e}"))?;
        bits.extend(out.iter().map(|x| x.to_bits()));
    }
    Ok(bits)
}
