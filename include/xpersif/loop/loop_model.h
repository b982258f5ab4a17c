/**
 * @file loop_model.h
 * @brief LOOPMODEL (organizational): the loop's centre. It starts, parametrizes, watches and restarts the
 *        loop's components (the `~components` list, as for any Supervisor: XPERSim, ROBOTMODEL,
 *        KNOWLEDGEBASE, MACHINELEARNING, MOTIVATION, DESIGNOFEXPERIMENTS, PLANNER, EXECUTION, GOALDESIGN)
 *        and runs the loop's state machine through the command `run` (xpersif/RunLoop):
 *
 *   experimenting   design an experiment (or take the hand-chosen / pre-planned one), plan it from the
 *                   contracts, predict it, execute it, compute the outcome, record it (MACHINELEARNING and
 *                   MOTIVATION learn from the recorded experiment), until the run has its experiments;
 *   goal_directed   GOALDESIGN sets goals ("bring the red cube to (x, y)") and chooses pushes with the
 *                   learned model; each push is planned and executed the same way;
 *   paused / waiting_for_confirmation   sliding autonomy: operations pause, resume, confirm, stop,
 *                   set_next_experiment.
 *
 * Everything that happens is in the knowledge base, so a run that was interrupted (a component died, the
 * whole system was stopped) resumes where it stopped (goal.resume). At the start of every step (an experiment,
 * a goal) it takes XPERSim's world state (`~checkpoint`) and stores it in the knowledge base; a resumed run puts
 * the world back in the state of the step it resumes at, and an experiment during which a component was lost
 * is not stored but done again from its step's state. With the lockstep clock, a run interrupted in any of these
 * ways ends with the same experiments as an uninterrupted one (test/determinism.sh). The arena is tidied between
 * experiments as an experimenter would: a cube pushed against a wall, against another cube or out of sight
 * is put back at a free spot (XPERSim's set_pose; a physical set-up would ask a person). Progress is published latched on
 * `~progress` (RunLoopFeedback).
 *
 * Features learned from: once a run has its first N experiments (N = `~select_features_after`, or all of the run's
 * experiments when it has fewer; 0: never) and goes on (a further experiment or a goal), LOOPMODEL asks FEATURESELECTION's `choose_features` to rank the object's
 * own features on them (seeded by core::streamSeed(seed, run, N, Features)), passes the choice to MACHINELEARNING's
 * `use_features` and waits until VISION's vectors carry the new selection; before that, at the start of every run, it
 * sets the initial ones (FEATURESELECTION's `select_features` with none, MACHINELEARNING's `use_features` with none).
 * Both are set again after any component was lost (a restarted one starts from its parameters), and a resumed run
 * asks for the choice again, which the stored experiments make the same. A choice FEATURESELECTION cannot make
 * (FAILED: too few experiments carry every candidate) leaves the initial features, with a warning. GOALDESIGN is
 * asked for a model that learns from exactly these features.
 *
 * Parameters: LoopModel::parameters() (its own, the Supervisor's and the lockstep client's; doc/parameters.md), and the `world` file for the arena (embodiment_setup.h).
 */
#pragma once

#include <actionlib/client/simple_action_client.h>
#include <std_srvs/Trigger.h>

#include <atomic>
#include <deque>
#include <functional>
#include <mutex>
#include <optional>
#include <map>
#include <random>

#include "xpersif/ExecutePlanAction.h"
#include "xpersif/ExperimentRecord.h"
#include "xpersif/FeatureVector.h"
#include "xpersif/LearnedModel.h"
#include "xpersif/MakePlan.h"
#include "xpersif/Motivation.h"
#include "xpersif/RunLoopAction.h"
#include "xpersif/SetExperiment.h"
#include "xpersif/component/lockstep_client.h"
#include "xpersif/component/supervisor.h"
#include "xpersif/core/common/experiment_failure.h"
#include "xpersif/core/planning/experiment_design.h"
#include "xpersif/core/common/setup.h"
#include "xpersif/embodiment/embodiment_setup.h"
#include "xpersif/ros/algorithm_loader.h"

namespace xpersif {

class LoopModel : public Supervisor {
 public:
  /// Its parameters, declared once (doc/parameters.md).
  static const core::ParameterTable& parameters();
  const core::ParameterTable* declaredParameters() const override { return &parameters(); }

  LoopModel(ros::NodeHandle nh, ros::NodeHandle private_nh);

  using Run = CommandServer<RunLoopAction>;

 protected:
  void onConfigure() override;

 private:
  // ---- its contracts (loop_model.cpp) ----
  /// The command `run` (xpersif/RunLoop) with its contract.
  void declareRun();
  /// The sliding autonomy's operations: pause, resume, stop, confirm (std_srvs/Trigger) and set_next_experiment.
  void declareOperations();
  /// One std_srvs/Trigger operation: checked by @p check ("" or why not), then @p act.
  void declareTrigger(const std::string& name, const std::string& description, const std::string& precondition,
                      const std::string& precondition_text, const std::string& effect,
                      std::function<std::string()> check, std::function<void()> act);

  // ---- the run, as named steps over one RunState (loop_model_run.cpp, loop_model_goals.cpp) ----
  struct RunState;
  struct NextExperiment;
  struct GoalAttempt;
  /// Where an experiment failed, with the code that stage gave and the overhead camera's latest vector then.
  struct StageFailure {
    core::ExperimentStage stage = core::ExperimentStage::None;
    std::uint8_t code = 0;              ///< xpersif/ResultCode
    std::optional<FeatureVector> seen;  ///< the last observation the plan made, when it made one
  };
  /// The run's outcome when it ends at a step; empty: the run goes on.
  using Ending = std::optional<CommandOutcome>;
  CommandOutcome run(Run::Context& context, RunLoopResult& result);
  /// Waits for the components, starts or resumes the run in the knowledge base, arranges a new run's arena
  /// and puts a resumed run's world back in the state of the step it resumes at.
  Ending startOrResume(RunState& run);
  /// Every component up (bounded by ~startup_timeout each); "" or why not.
  std::string waitForComponents(RunState& run);
  /// The knowledge base's start_run (its answer in run.start); "" or why not.
  std::string startInKnowledgeBase(RunState& run);
  /// The progress at the run's start: started or resumed, what is done and what is left.
  void announceStart(RunState& run);
  /// The world as it was at the step a resumed run resumes at (a restarted simulator starts from the world file).
  void restoreResumedWorld(RunState& run);
  /// The designed experiments, until the run has goal.experiments of them.
  Ending experimentPhase(RunState& run);
  /// One experiment: its world state, the gate, the scene, the choice, the experiment, and what is stored of it.
  Ending experimentStep(RunState& run);
  /// The world state the step starts from: the one the last step left, or a new checkpoint.
  Ending takeStepState(RunState& run);
  /// The features learned from, the scene observed and tidied (drawing from the stream of step @p step).
  Ending sceneForStep(RunState& run, std::uint64_t step, FeatureVector& scene);
  /// The hand-chosen experiment queued first, else DESIGNOFEXPERIMENTS's.
  Ending chooseExperiment(RunState& run, const FeatureVector& scene, NextExperiment& next);
  /// Back to the step's world state once the lost components are back, to do the experiment again.
  Ending redoExperiment(RunState& run, const NextExperiment& next, const ExperimentRecord& record, bool replaced,
                        bool designed_before_any_loss);
  /// The world state after the experiment (the next step's start), then the experiment, in the knowledge base.
  Ending storeExperiment(RunState& run, const ExperimentRecord& record, const std::string& end_why,
                         const std::string& end_state);
  /// @p record as an experiment of run @p run_id in the knowledge base; "" or why not.
  std::string storeRecord(std::uint64_t run_id, const ExperimentRecord& record);
  /// Counts a stored experiment, waits for MACHINELEARNING to learn a successful one, and publishes progress.
  void countExperiment(RunState& run, const Experiment& experiment, const ExperimentRecord& record);
  /// Ends the run when the experiment just counted is the ~max_same_failures-th in a row failing for one cause
  /// (core::FailureStreak), naming that cause and the last experiment's reason.
  Ending checkFailureStreak(RunState& run, const ExperimentRecord& record, const StageFailure& failure,
                            const FeatureVector& scene);
  /// The goals GOALDESIGN sets, until the run has goal.goals of them.
  Ending goalPhase(RunState& run);
  /// One goal: its world state, the gate, the scene, the goal, its pushes, and the goal stored.
  Ending goalStep(RunState& run, std::uint32_t g);
  /// The goal's world state, stored in the knowledge base.
  Ending checkpointGoal(RunState& run, const GoalAttempt& attempt);
  /// GOALDESIGN's goal for the scene.
  Ending designGoal(RunState& run, GoalAttempt& attempt);
  /// Pushes until the object is close enough to the target or the goal has had ~max_goal_pushes.
  Ending pursueGoal(RunState& run, GoalAttempt& attempt);
  /// One push chosen by GOALDESIGN, executed and stored (or done again when a component was lost).
  Ending pushOnce(RunState& run, GoalAttempt& attempt, int push);
  /// GOALDESIGN's push number @p push (0-based) towards the goal; none (with a warning) when it chose none.
  std::optional<Experiment> choosePush(RunState& run, const GoalAttempt& attempt, int push);
  /// After a stored push: learns from it and sees the scene it left.
  void afterPush(RunState& run, GoalAttempt& attempt, const ExperimentRecord& record);
  /// The goal reached or missed, in the knowledge base and the progress.
  Ending recordGoal(RunState& run, GoalAttempt& attempt);
  /// Logs where the run's wall time went, and tells the knowledge base and the progress that it ended as @p status.
  void finish(RunState& run, const std::string& status);
  /// Ends the run (stopped) for @p reason: PREEMPTED when cancelled, else ABORTED; @p code goes to the result
  /// (RunLoopResult::REPEATING_CAUSE when every experiment left would fail the same way).
  CommandOutcome ended(RunState& run, const std::string& reason, std::uint8_t code = 0);
  /// Ends the run because VISION gave no vectors (@p what, @p why): naming the perceiving component that refuses
  /// to work (perceptionRefusal, REPEATING_CAUSE) when there is one.
  CommandOutcome blind(RunState& run, const std::string& what, const std::string& why);
  /// Ends the run before @p step ("experiment 4", "goal 2", "push 3 of goal 2") when a component it needs is in ERROR (failedComponent),
  /// naming it and its error (REPEATING_CAUSE): every step would fail, and downstream of it.
  Ending stopIfAComponentFailed(RunState& run, const std::string& step);
  /// Ends the run because the knowledge base did not store @p what (@p why).
  CommandOutcome unstored(RunState& run, const std::string& what, const std::string& why);
  /// Ends the run finished, SUCCEEDED with its counts.
  CommandOutcome finished(RunState& run);
  /// The successful experiments MACHINELEARNING should have learned once it learned one more.
  std::uint32_t learnedOneMore(RunState& run);

  // ---- one experiment (loop_model_experiment.cpp) ----
  /// One experiment, start to end, of the run @p record.run_id names; fills @p record (status done or failed, with
  /// the reason) and, when given,
  /// @p failure with the stage that failed, its code and the camera's latest vector.
  void runExperiment(const Experiment& experiment, const std::string& design, Run::Context& context,
                     ExperimentRecord& record, StageFailure* failure = nullptr);
  /// The PLANNER's plan for @p experiment: observe, push, observe again; "" or why not (its code in @p failure).
  std::string planExperiment(const Experiment& experiment, Run::Context& context, MakePlan& plan,
                             StageFailure& failure);
  /// EXECUTION runs @p plan; the observations before and after go to @p record; "" or why it failed (its code
  /// and the last observation the plan made in @p failure).
  std::string executePlan(const MakePlan& plan, Run::Context& context, ExperimentRecord& record,
                          StageFailure& failure);
  /// MACHINELEARNING's prediction and the outcome observed, with the surprise, in @p record; "" or why not.
  std::string compareWithPrediction(const Experiment& experiment, ExperimentRecord& record, StageFailure& failure);
  /// What @p failure, the step's @p scene and ~pose_source say of why @p record failed, for core::classifyFailure.
  core::FailureEvidence evidenceOf(const ExperimentRecord& record, const StageFailure& failure,
                                   const FeatureVector& scene) const;

  // ---- the progress and sliding autonomy (loop_model.cpp) ----
  /// "" or why the loop must end now (cancel, stop, shutdown); waits while paused or unconfirmed.
  std::string gate(Run::Context& context, bool confirm_each);
  void setState(const std::string& state);
  void publishProgress(Run::Context* context);

  // ---- the arena (loop_model_arena.cpp) ----
  /// Put cubes pushed against the walls, against each other or out of sight back at random free places drawn
  /// from @p stream (core::streamSeed).
  int tidyArena(const FeatureVector& scene, std::uint64_t stream);  ///< how many objects it moved
  /// The set-up's catalogue, read from XPERSim's scene the first time it is needed (XPERSim is one of the
  /// components LOOPMODEL starts, so not at configure). @throws std::runtime_error when it cannot be had
  const core::SetupCatalogue& catalogue();
  /// Put the objects and the robot where the world file has them (a new run starts from the same arena).
  std::string arrangeInitialScene();
  /// The run's start: arrange the scene and let it settle, again if the simulator was restarted meanwhile.
  void arrangeAndSettle();
  bool getScene(FeatureVector* scene, std::string* why);

  // ---- checkpoints and lost components (loop_model_checkpoints.cpp) ----
  /// XPERSim's world state at the start of step @p step of run @p run_id, stored in the knowledge base; the world
  /// goes on from it exactly as a world restored from it. Returns it, or "" (with a warning) when XPERSim could not
  /// give it; when the knowledge base did not store it, @p refused says why (the caller ends the run).
  std::string takeCheckpoint(std::uint64_t run_id, std::uint32_t step, std::string* refused);
  /// Stores @p state as the world state at step @p step of run @p run_id; "" or why the knowledge base did not.
  std::string storeWorldState(std::uint64_t run_id, std::uint32_t step, const std::string& state);
  /// XPERSim's checkpoint only (kept in memory by the caller); "" with @p why set when it could not be had.
  std::string checkpointWorld(std::string* why);
  /// Put the world back in @p state, or in the state stored for @p step of @p run_id when @p state is empty;
  /// "" or why not.
  std::string restoreCheckpoint(std::uint64_t run_id, std::uint32_t step, const std::string& state = "");
  /// Waits (up to 10 s of wall time) until this process's clock shows @p restored_clock, the simulated time a
  /// restored world goes on from, so that the next scene read is one of that world.
  void awaitClock(double restored_clock);
  /// Whether a component was lost during the experiment that gave @p record (a failed one first waits one
  /// heartbeat timeout: its failure may be the first sign of the loss).
  bool lostDuring(std::uint64_t losses_before, const ExperimentRecord& record);
  /// A failed @p record whose step ended with a component in ERROR failed downstream of it: its reason names that
  /// component's error first (call after lostDuring, which gave the component's status time to arrive).
  void nameFailedComponent(ExperimentRecord& record) const;
  /// Once no component is lost any more (up to 180 s), the world back in @p state; "" or why not.
  std::string returnTo(Run::Context& context, std::uint64_t run_id, const std::string& state);
  void onComponentLost(const SupervisedComponent& component, const std::string& reason) override;

  // ---- learning and the features learned from (loop_model_features.cpp) ----
  /// Samples of MACHINELEARNING's latest model (GOALDESIGN waits for the same model).
  std::uint32_t modelSamples();
  /// What MACHINELEARNING learns from, as its use_features answered (GOALDESIGN waits for that model).
  std::vector<std::string> learningFeatures();
  /// Until MACHINELEARNING's model is of run @p run_id with @p samples samples (up to ~learning_timeout; a model
  /// of the run before, however many samples it has, is not this run's).
  void waitForLearning(std::uint64_t run_id, std::uint32_t samples, Run::Context& context);

  /// Which features the run learns from, and how far that is applied (the run's thread only).
  struct FeatureStage {
    int applied = -1;  ///< -1: nothing yet in this run, 0: the initial features, 1: FEATURESELECTION's choice
    std::uint64_t losses = 0;  ///< losses_ when it was applied
  };
  /// The initial features before the run's first `~select_features_after` experiments (of @p experiments), the
  /// choice from then on, applied unless @p stage says it is (and no component was lost since); "" or why not.
  std::string ensureFeatures(std::uint64_t run_id, std::uint64_t seed, std::uint32_t done, std::uint32_t experiments,
                             FeatureStage& stage);
  /// Until VISION's latest vector carries exactly @p selection for every object (20 s of wall time); "" or why not.
  std::string waitForSelection(const std::vector<std::string>& selection);
  /// "" or what a component behind VISION refuses, from the statuses: a supervised component reporting a part in
  /// HEALTH_ERROR (ROBOTMODEL: OBSERVATION), and that part's own status naming its part in HEALTH_ERROR and why
  /// (OBSERVATION's feature_extraction: "cannot extract features from camera 'overhead': ..."). Decided on the
  /// health codes, never on the words.
  std::string perceptionRefusal();
  void onComponentStatus(const std::string& name, const ComponentStatus& status) override;

  std::mutex mutex_;
  EmbodimentSetup setup_;
  std::optional<core::SetupCatalogue> catalogue_;  // read from XPERSim's scene once XPERSim is up
  std::mutex catalogue_mutex_;
  // Which designs exist (a run's design must be one): asked of pluginlib, never listed here.
  std::mutex designs_mutex_;
  AlgorithmLoader<core::ExperimentDesign> designs_{"xpersif::core::ExperimentDesign", "experiment design"};
  std::unique_ptr<LockstepClient> lockstep_;  // lets simulated time pass while it waits (lockstep mode)
  // EXECUTION's execute_plan, made once: an action client takes ~0.25 s to connect (bench/loop_speed.md).
  std::unique_ptr<actionlib::SimpleActionClient<ExecutePlanAction>> execution_;
  std::string pose_source_ = "observation";
  int retries_ = 1;
  bool tidy_ = true, arrange_at_start_ = true;
  double tidy_margin_ = 0.13, tidy_spacing_ = 0.14, goal_tolerance_ = 0.02, learning_timeout_ = 20.0;
  int max_goal_pushes_ = 5;
  std::uint32_t select_features_after_ = 16;
  std::uint32_t max_same_failures_ = 3;
  // The parts in HEALTH_ERROR of each supervised component's latest status (guarded by mutex_).
  std::map<std::string, std::vector<PartStatus>> erroring_parts_;
  std::vector<std::string> learning_features_;  // what MACHINELEARNING learns from (use_features' answer)

  std::atomic<bool> running_{false}, paused_{false}, stop_requested_{false}, waiting_confirmation_{false};
  std::atomic<int> confirmations_{0};
  std::atomic<std::uint64_t> losses_{0};  // components lost so far (a step that saw one is done again)
  std::string world_lineage_;  // XPERSim's lineage of the world last checkpointed or restored (loop thread only)
  double latest_clock_ = 0;  // the latest simulated time the run's thread saw (a restored world's clock goes on after it)
  std::deque<Experiment> next_experiments_;  // hand-chosen, run before designed ones
  RunLoopFeedback progress_;
  std::uint64_t model_run_ = 0;  // the run MACHINELEARNING's latest model is of
  std::uint32_t model_samples_ = 0;
  /// Wall seconds the current run spent in each step (scene, tidy, design, plan, execution, predict, record,
  /// learning), logged at its end: where a campaign's time goes (bench/loop_speed.md).
  std::map<std::string, double> wall_spent_;
  /// Adds the wall time from construction to destruction to wall_spent_[step] (only the run's thread uses it).
  struct Spending {
    Spending(std::map<std::string, double>& spent, const char* step)
        : spent(spent), step(step), since(ros::WallTime::now()) {}
    ~Spending() { spent[step] += (ros::WallTime::now() - since).toSec(); }
    std::map<std::string, double>& spent;
    const char* step;
    ros::WallTime since;
  };

  ros::Publisher progress_pub_;
  ros::Subscriber model_sub_;
};

}  // namespace xpersif
