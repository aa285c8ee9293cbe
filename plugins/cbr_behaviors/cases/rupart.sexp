; RUPART's initial case memory (004): hand-made behavior cases, plan cases, meta-plans and
; adaptation strategies, for the office floor of cbr_world2d.generate.office (default
; arguments: rooms room_1 .. room_8, hallway ends hall_west and hall_east).
;
; Sonar clauses list the 16 ranges in metres in the Pioneer ring order (front ring 90 50 30 10
; -10 -30 -50 -90 degrees, rear ring -90 -130 -150 -170 170 150 130 90); one number stands for
; all 16. A range of 5.0 is no echo. In a hallway 2 m wide the side beams read 1 m, the beams
; 50 degrees off the axis 1.3 m, 30 degrees off 2 m and those along it nothing.
; Behavior parameters are centimetres, cm/s and deg/s, or the named levels.
;
; cases/rupart.yaml is this file exported as a case base (cbr_behaviors.casefiles.export).

; --- behavior cases ---------------------------------------------------------------------------
;
; Indexed by the situation features (docs/rupart.md): front, left, right, rear (the nearest
; sonar reading in each sector over 5 m), width (free width across the robot over 4 m), person,
; person-bearing, closing (the nearest person in view: distance over 5 m, bearing over 180
; degrees, closing speed over 1.5 m/s), door, door-shut (the doorway ahead on the route:
; distance over 5 m, shut or open) and progress (the part of the route driven). A feature left
; out does not count. The values are those the robot reads in each situation, measured on the
; tuning floors (docs/rupart.md, "The case memory"): in a clear hallway 2 to 2.6 m wide the
; nearest reading ahead is about 1.5 m (front 0.3), the free width about 2.4 m (width 0.6).
; The sets keep avoidCollision short (20 to 25 cm): a longer one stops the robot in every
; doorway, whose jambs pass 20 to 35 cm from its rim. Two profiles serve the hallway: where
; nobody is in the way, fast (goToPos 70 cm/s, avoidObstacle at 30 cm only, so that the walls of
; a hallway 2 m wide do not hold it to 20 cm/s, and slowAvoid slowing it for what comes within
; 80 cm straight ahead); with a person ahead, careful (slowAvoid from 1.2 m, backOff). No fixed
; set can be both: the fast one alone drives into someone or something three times a day on
; the tuning floors.

; 004 Figure 4 (a): an open area with few obstacles, as printed (moderately fast, turning away
; from obstacles 1.5 m off, avoiding collisions half a metre off)
(behavior-case open-area
  (plan-index (front 1.0) (width 1.0) (person 1.0) (door 1.0))
  (((goStraight mod-fast curr-head) med)
   ((avoidObstacle 150 moderate) med)
   ((goToPos curr-goal mod-fast 100) high)
   ((avoidCollision 50 mod-fast) high)))

; 004 Figure 4 (b): a hallway with many obstacles, most likely pedestrians. Its slowAvoid and
; avoidCollision, the careful profile: as printed (followWall and moveForward, slow, very-slow)
; it crawled at 0.04 m/s through every crowded stretch of the tuning floors; slowAvoid from
; 1.2 m slows it the nearer people come, and backOff gives way to one who stopped
(behavior-case crowded-hallway
  (plan-index (front 0.1) (left 0.1) (right 0.1) (width 0.5) (person 0.2))
  (((goToPos curr-goal 60 20) high)
   ((avoidObstacle 30 moderate) med)
   ((slowAvoid 120 slow) high)
   ((avoidCollision 25 moderate) high)
   ((backOff 25 slow) high)))

; a hallway with nobody in view and no doorway near: the fast profile
(behavior-case clear-hallway
  (plan-index (front 0.3) (width 0.6) (person 1.0) (closing 0.0) (door 0.75) (door-shut 0.0))
  (((goToPos curr-goal 70 20) high)
   ((avoidObstacle 30 moderate) med)
   ((slowAvoid 80 slow) high)
   ((avoidCollision 20 moderate) high)
   ((backOff 15 slow) high)))

; urgent, and the way clear: the fast profile
(behavior-case urgent-clear-way
  (plan-index (front 0.3) (width 0.6) (person 1.0) (door 0.75) (task-urgency 1.0)
              (goal-urgency 1.0))
  (((goToPos curr-goal 70 20) high)
   ((avoidObstacle 30 moderate) med)
   ((slowAvoid 80 slow) high)
   ((avoidCollision 20 moderate) high)
   ((backOff 15 slow) high)))

; inside a room, nobody in view: the fast profile (slowAvoid slows it for the furniture)
(behavior-case clear-room
  (plan-index (width 0.95) (person 1.0) (door 0.45))
  (((goToPos curr-goal 70 20) high)
   ((avoidObstacle 30 moderate) med)
   ((slowAvoid 80 slow) high)
   ((avoidCollision 20 moderate) high)
   ((backOff 15 slow) high)))

; someone in view but not in the way (beside the robot, or walking off): the fast profile; a
; person coming into the way fires the `person` trigger, which retrieves at once
(behavior-case person-aside
  (plan-index (person 0.4) (person-bearing 0.6) (closing 0.0))
  (((goToPos curr-goal 70 20) high)
   ((avoidObstacle 30 moderate) med)
   ((slowAvoid 80 slow) high)
   ((avoidCollision 20 moderate) high)
   ((backOff 15 slow) high)))

; someone behind, not gaining: carry on, the fast profile
(behavior-case person-behind
  (plan-index (person 0.3) (person-bearing 1.0) (closing 0.0))
  (((goToPos curr-goal 70 20) high)
   ((avoidObstacle 30 moderate) med)
   ((slowAvoid 80 slow) high)
   ((avoidCollision 20 moderate) high)
   ((backOff 15 slow) high)))

; a person ahead coming closer: the careful profile, slowing the nearer they come
(behavior-case approaching-person
  (plan-index (person 0.25) (person-bearing 0.1) (closing 0.3))
  (((goToPos curr-goal 60 20) high)
   ((avoidObstacle 30 moderate) med)
   ((slowAvoid 120 slow) high)
   ((avoidCollision 25 moderate) high)
   ((backOff 25 slow) high)))

; a person right in front: the careful profile; people stop for the robot, so it backs off
; from one who stands within 25 cm and goes round
(behavior-case person-close
  (plan-index (front 0.1) (person 0.05) (closing 0.2))
  (((goToPos curr-goal 60 20) high)
   ((avoidObstacle 30 moderate) med)
   ((slowAvoid 120 slow) high)
   ((avoidCollision 25 moderate) high)
   ((backOff 25 slow) high)))

; at an open doorway on the route: head for its waypoints on the axis, let the jambs come close
(behavior-case doorway
  (plan-index (door 0.12) (door-shut 0.0) (person 1.0))
  (((goToPos curr-goal 30 10) high)
   ((avoidCollision 15 moderate) med)
   ((backOff 10 slow) high)))

; the doorway ahead is shut: draw up before it and wait, doors of this building open again
(behavior-case door-shut
  (plan-index (door 0.2) (door-shut 1.0))
  (((goToPos curr-goal 40 10) med)
   ((slowAvoid 100 0) high)
   ((avoidCollision 25 moderate) high)))

; something in the way ahead that is not a person (a cart, a corner the route bends round)
(behavior-case blocked-ahead
  (plan-index (front 0.06) (person 1.0))
  (((goToPos curr-goal 45 20) high)
   ((avoidObstacle 80 slow) high)
   ((avoidCollision 25 moderate) high)
   ((backOff 30 slow) high)))

; a passage barely wider than the robot: straight on, slowly, collisions avoided late
(behavior-case narrow-passage
  (plan-index (width 0.35) (person 1.0) (door 1.0))
  (((goToPos curr-goal 30 20) high)
   ((avoidCollision 18 moderate) high)
   ((backOff 12 slow) high)))

; near the goal: slower, precise, close obstacles allowed
(behavior-case near-the-goal
  (plan-index (progress 1.0) (person 1.0))
  (((goToPos curr-goal 40 10) high)
   ((avoidObstacle 40 slow) med)
   ((avoidCollision 20 slow) high)))

; the odometry has drifted: stand and turn so that the map subsystem localizes from the
; landmarks in view, then go on
(behavior-case lost
  (plan-index (loc-conf 0.3))
  (((localize) high)
   ((goToPos curr-goal moderate 20) med)
   ((avoidCollision 25 moderate) high)))

; --- meta-plans: generic fall-backs when no case matches well --------------------------------

; move away: back out of where the robot is stuck, into the open
(meta-plan move-away
  (plan-index (behav-conf 0.0) (front 0.1))
  (((backOff 60 slow) high)
   ((goStraight slow curr-head) med)
   ((avoidObstacle 120 slow) high)
   ((avoidCollision 25 moderate) high)))

; localize here: stand and turn, observing for the localization algorithm
(meta-plan localize-here
  (plan-index (loc-conf 0.1))
  (((localize) high)
   ((avoidCollision 40 moderate) high)))

; turn and look: half a turn on the spot, for the sonar to see the other way
(meta-plan turn-and-look
  (plan-index (motors 0.0 0.0) (behav-conf 0.2))
  (((turnTo curr-head 180) high)
   ((avoidCollision 40 moderate) high)))

; --- plan cases: routes over the office floor's places --------------------------------------

(plan-case west-to-east
  (plan-index (location 0.75 5.0) (task-loc 15.25 5.0) (plan-conf 0.2))
  (route hall_west hall_east))

(plan-case east-to-west
  (plan-index (location 15.25 5.0) (task-loc 0.75 5.0) (plan-conf 0.2))
  (route hall_east hall_west))

(plan-case deliver-west-room
  (plan-index (goal deliver room_1 ?priority) (plan) (plan-conf 0.2))
  (route hall_west room_1))

(plan-case deliver-east-room
  (plan-index (goal deliver room_8 ?priority) (plan) (plan-conf 0.2))
  (route hall_east room_8))

; lost: localize first, then by the west end of the hallway, a place easy to recognise
(plan-case relocalize-west
  (plan-index (loc-conf 0.2) (plan-conf 0.3))
  (route hall_west)
  (localize))

; --- adaptation strategies -------------------------------------------------------------------

; 004: "decreasing the speed in behaviors like moveForward if sonar or map values show objects
; closer to the robot than in the retrieved case", by more the larger the difference: here the
; nearest reading ahead
(alter-strategy slow-when-closer
  (adapts behavior) (feature front) (sense closer) (min 0.1)
  (change (moveForward goStraight goToPos avoidObstacle slowAvoid) speed -1.0))

; the other way: the way ahead is clearer than in the case, so drive faster
(alter-strategy speed-up-when-farther
  (adapts behavior) (feature front) (sense farther) (min 0.1)
  (change (moveForward goStraight goToPos) speed 1.0))

; a person nearer than in the case: turn away from them earlier
(alter-strategy widen-when-crowded
  (adapts behavior) (feature person) (sense closer) (min 0.15)
  (change (avoidObstacle avoidCollision slowAvoid) distance 1.0))

; a person farther than in the case: they need less room
(alter-strategy narrow-when-clear
  (adapts behavior) (feature person) (sense farther) (min 0.15)
  (change (avoidObstacle slowAvoid) distance -0.5))

; 004: merge "when the retrieved behavior case has very high distance values on some
; features and very low values on others"
(merge-strategy merge-mismatch (adapts behavior) (high 0.6) (low 0.2))
