% The notes' section 1 m-function, as printed (point masses, relative angles theta and phi), for
% `lagrange-xval check --model models/double_pendulum_point.xml --equations examples/matlab/double_bob_pendulum.m`.
% The printed dydt(3) lacks a closing parenthesis; it is closed before the semicolon.
% coordinates: theta, phi
function dydt = double_bob_pendulum(t,y)
theta = y(1);
phi = y(2);
dthetadt = y(3);
dphidt = y(4);
g = 9.81;
l = 1;
m = 1;
dydt = zeros(4,1);
dydt(1) = dthetadt;
dydt(2) = dphidt;
dydt(2) = dphidt;
dydt(3) = 1/(2 + (cos(phi))^2) * ((2 + cos(phi)) * sin(phi) * dphidt^2 + ...
cos(phi) * g/l * sin(theta+phi) + 2 * sin(phi) * dphidt * dthetadt - 2 * g/l * sin(theta));
dydt(4) = -(1 + cos(phi))/(2 + (cos(phi))^2) * ((2 + cos(phi)) * sin(phi) * dphidt^2 + ...
cos(phi) * g/l * sin(theta+phi) + 2 * sin(phi) * dphidt * dthetadt - 2 * g/l * sin(theta)) - ...
sin(phi) * dthetadt^2 - g/l * sin(phi + theta);
